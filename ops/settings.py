"""The method's parameters, with the paper's defaults: one frozen dataclass every front end shares.

Dagster exposes it as the `settings` resource (resources/settings.py, derived
from these fields); the CLI, the editor and the run planner build it directly,
without importing Dagster.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

OCCLUSION_PREDICTORS = ("skeleton", "hybrid", "pairs", "drawing")  # Settings.occlusion's values


def _doc(text: str) -> dict:
    return {"doc": text}


@dataclass(frozen=True)
class Settings:
    """Parameters of the method; a stage records the values it read, so changing one re-runs exactly its readers."""

    mu: float = field(default=200.0, metadata=_doc("Weight of the pose term in the deformation energy (§4.3)."))
    grad_tol: float = field(default=0.01, metadata=_doc("Stop the quasi-Newton solver at this gradient norm (§4.3)."))
    max_iter: int = field(default=5000, metadata=_doc("Iteration cap of the deformation solver (§4.3)."))
    topology_budget: float = field(default=30.0, metadata=_doc(
        "Wall-clock seconds the cut search may spend on one occlusion region (§4.4); when they run out the best "
        "cut found so far is kept, with a warning."))
    implied_cuts: bool = field(default=True, metadata=_doc(
        "An occlusion region the user clicked no T-junction on also tries the cut its outline implies (§4.4, "
        "extended): the front sewn where the covering part continues across the region's boundary, the pocket "
        "where only the covered part does (ops/geometry/implied_cut.py); the cut search keeps it where it "
        "deforms with less energy than the region's two uniform cuts."))
    epsilon: float = field(default=0.02, metadata=_doc("Path may step back in alpha by less than this (§5.2)."))
    alpha_depth: int = field(default=3, metadata=_doc("Depth of the image matrix's dyadic alpha grid: 2**depth + 1 values (§5.2)."))
    matrix_cells: str = field(default="scaled", metadata=_doc(
        "How the image matrix's cells off alpha 1/2 are made (§5.2): 'scaled' (default) from each row's one RIFE "
        "call at alpha 1/2, its flows scaled to alpha; 'bisection' by recursive RIFE midpoints, as the paper (up "
        "to three calls a cell; ops/blending/image_matrix.py)."))
    local_alpha: float = field(default=2.0, metadata=_doc(
        "Per-pixel alpha (§5.2, extended): each interior frame's alpha moved by this strength times the difference "
        "of the lanes' unreliable texture (inpainted or torn, as q counts it) around each pixel, toward the "
        "reliable lane (ops/blending/local_alpha.py); 0 keeps one alpha per frame, as the paper."))
    key_fallback: float = field(default=6.0, metadata=_doc(
        "Where both lanes' texture is unreliable at once (torn or inpainted in both), and where the two lanes' tears "
        "meet but RIFE does not ghost, each interior frame takes RIFE's interpolation of the two keys, weighted by "
        "the lanes' unreliable masks blurred over this many pixels (ops/blending/key_fallback.py); 0 turns it off."))
    supersample: int = field(default=2, metadata=_doc("Renderer supersampling factor per axis (anti-aliasing)."))
    template_mode: str = field(default="optimized",
                               metadata=_doc("'optimized' (2.5D template, §4.4) or 'single-layer' (ablation)."))
    register_lanes: bool = field(default=True, metadata=_doc(
        "Register each lane, where it reaches the segment's other key, onto that key's drawing (optical flow at "
        "the visible vertices, solved injectively) and fade the displacement in over the segment, so that both "
        "lanes arrive where the drawings are (ops/geometry/register.py, docs/lanes.md)."))
    blend: str = field(default="optimal", metadata=_doc("'optimal' shortest-path blending or 'diagonal' alpha = t (§5.2)."))
    occlusion: str = field(default="hybrid", metadata=_doc(
        "Occlusion masks when none are given (§4.1): 'skeleton' from the skeleton alone (overlapping bodies of "
        "non-adjacent bones); 'hybrid' (default) the skeleton rule's regions, each cut to where the drawing shows "
        "the front part (a small network's marks, ops/segmentation/occlusion_drawing.py, or the front bones' "
        "bodies between the drawing's strokes, whichever keeps more), kept whole where neither sees enough of "
        "it, fronts checked against the drawing; 'pairs' the hybrid's regions split into one per overlapping bone "
        "pair, each with its own front; 'drawing' the network's own regions, one per overlapping bone pair "
        "with the front read off the drawing where it shows, far nearer the truth (IoU 0.70 against 0.52 on "
        "held-out body and style families) but, built into templates today, worse in-betweens on three of four "
        "shots (docs/occlusion.md)."))

    def as_dict(self) -> dict:
        """{name: value} of every parameter."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


class RecordingSettings:
    """Read-only view of Settings that remembers which parameters were read (a stage's provenance)."""

    def __init__(self, settings: Settings):
        self._settings = settings
        self.read: dict = {}

    def __getattr__(self, name: str):
        value = getattr(self._settings, name)  # AttributeError for unknown names, as on the dataclass
        self.read[name] = value
        return value
