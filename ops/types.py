"""Dataclasses passed between pipeline stages.

Conventions: image coordinates in pixels, x right, y down, origin at the
top-left pixel's centre; images float32 in [0, 1] with straight alpha;
masks bool (H, W). Every array's shape and unit is named on its field.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Skeleton:
    """Joint names and the parent of each joint (-1 for the single root)."""

    joints: tuple[str, ...]
    parents: np.ndarray  # (J,) int64

    @property
    def bones(self) -> np.ndarray:
        """(B, 2) int64 (parent, child) joint index pairs, in child order."""
        child = np.nonzero(self.parents >= 0)[0]
        return np.stack([self.parents[child], child], axis=1).astype(np.int64)

    def adjacent_bones(self) -> np.ndarray:
        """(B, B) bool: bones sharing a joint (a bone is adjacent to itself)."""
        b = self.bones
        share = (b[:, None, :, None] == b[None, :, None, :]).any(axis=(2, 3))
        return share


@dataclass
class Shot:
    """A validated shot directory (see SHOT_FORMAT.md)."""

    root: str  # absolute path of the shot directory
    keyframes: tuple[str, str]  # absolute image paths
    size: tuple[int, int]  # (H, W) pixels
    skeleton: Skeleton
    times: np.ndarray  # (T,) float64 output times, first 0, last 1
    poses: np.ndarray  # (T, J, 3) float64 joint x, y (pixels), z (depth, larger = farther)
    t_junctions: tuple[np.ndarray, np.ndarray]  # per keyframe (k, 2) float64 pixels
    foreground_masks: tuple[str | None, str | None]  # manual mask paths or None
    occlusion_masks: tuple[tuple[str, ...], tuple[str, ...]]  # manual masks per keyframe
    ground_truth: str | None = None  # folder of reference frames, or None
    frames_given: int | None = None  # the optional `frames` field

    def key_pose(self, k: int) -> np.ndarray:
        """(J, 3) pose at keyframe k (0 -> t = 0, 1 -> t = 1)."""
        return self.poses[0 if k == 0 else -1]


@dataclass
class Masks:
    """Foreground and occlusion masks of one keyframe (§4.1)."""

    foreground: np.ndarray  # (H, W) bool, True = character
    occlusion: list[np.ndarray]  # per region (H, W) bool, inside foreground, sorted back to front
    front_bones: list[np.ndarray]  # per region (b,) int64 bone indices drawn in front in that region
    source: str  # "manual" | "predicted" | "mixed"
    warnings: list[str] = field(default_factory=list)


@dataclass
class RefinedMasks:
    """Occlusion masks deformed so their boundaries pass through the T-junctions (§4.1)."""

    foreground: np.ndarray  # (H, W) bool
    occlusion: list[np.ndarray]  # per region (H, W) bool
    front_bones: list[np.ndarray]  # per region (b,) int64
    boundaries: list[np.ndarray]  # per region (n, 2) float64 closed polyline (first != last), pixels, DP 2 px
    junctions: list[np.ndarray]  # per region (k,) int64 indices into that region's boundary polyline
    foreground_boundary: np.ndarray  # (m, 2) float64 outer boundary polyline, pixels
    warnings: list[str] = field(default_factory=list)


@dataclass
class Template:
    """2.5D partially layered template mesh (§4.2-4.4).

    Layer 0 is the front sheet covering the whole foreground; layer r + 1 is
    the pocket (the occluded part behind) of occlusion region r.
    """

    rest: np.ndarray  # (n, 2) float64 rest vertex positions, pixels (keyframe image space)
    faces: np.ndarray  # (m, 3) int64, counter-clockwise in image coordinates (y down -> positive signed area)
    face_layer: np.ndarray  # (m,) int64 layer of each face
    handles: np.ndarray  # (h,) int64 vertex indices constrained by the pose term
    handle_weights: np.ndarray  # (h, J) float64: handle target = handle_weights @ joints_xy
    cut_assignment: list[np.ndarray]  # per region (s,) int8, per boundary segment 0 = sewn to front, 1 = sewn to back
    energy: float  # deformation energy to the other keyframe's pose with the chosen topology
    trials: int  # topologies evaluated
    mode: str  # "optimized" | "single-layer"
    warnings: list[str] = field(default_factory=list)

    def handle_targets(self, pose: np.ndarray) -> np.ndarray:
        """(h, 2) float64 handle target positions for a (J, 3) pose."""
        return self.handle_weights @ pose[:, :2]


@dataclass
class TexturedTemplate:
    """Template with depth weights and per-face texture (§5.1)."""

    template: Template
    weights: np.ndarray  # (n, J) float64 bounded biharmonic weights, rows sum to 1
    face_source: np.ndarray  # (m,) int64: 0 = drawing, 1 = other keyframe, 2 = inpainted
    texture: np.ndarray  # (H, W, 4) float32 front texture = the keyframe drawing, alpha = foreground
    back_texture: np.ndarray  # (H, W, 4) float32 texture of the pockets in rest coordinates
    back_inpainted: np.ndarray  # (H, W) bool pixels of back_texture that were inpainted

    def face_depth(self, pose: np.ndarray) -> np.ndarray:
        """(m,) float64 depth of each face at a (J, 3) pose (larger = farther)."""
        vertex_depth = self.weights @ pose[:, 2]
        return vertex_depth[self.template.faces].mean(axis=1)


@dataclass
class DeformedSequence:
    """One keyframe's template deformed into every output pose (§5.1)."""

    times: np.ndarray  # (T,) float64
    vertices: np.ndarray  # (T, n, 2) float64 deformed positions, pixels
    images: np.ndarray  # (T, H, W, 4) float32 rendered RGBA, straight alpha
    inpainted: np.ndarray  # (T, H, W) bool: visible pixels whose texture was inpainted
    energies: np.ndarray  # (T,) float64 final energy per frame
    iterations: np.ndarray  # (T,) int64 solver iterations per frame


@dataclass
class ImageMatrix:
    """RIFE blends I(alpha, t) of the two deformed sequences (§5.2)."""

    times: np.ndarray  # (T,) float64
    alphas: np.ndarray  # (A,) float64 dyadic grid, 0 .. 1
    frames: np.ndarray  # (T, A, H, W, 4) float32 (may be a np.memmap for long shots)
    flows: np.ndarray  # (T, H, W, 4) float32 RIFE flow at alpha = 1/2: (u0, v0) to frame 0, (u1, v1) to frame 1, pixels


@dataclass
class BlendPath:
    """A path through the image matrix: one alpha index per time (§5.2)."""

    alpha_index: np.ndarray  # (T,) int64
    cost: float
    step_costs: np.ndarray  # (T - 1,) float64 cost of each transition
    abrupt: np.ndarray  # (T - 1,) bool transitions far above the median cost


@dataclass
class BlendPaths:
    """The optimal and the diagonal path through one shot's image matrix (§5.2)."""

    times: np.ndarray  # (T,) float64
    alphas: np.ndarray  # (A,) float64
    optimal: BlendPath
    diagonal: BlendPath


@dataclass
class OutputFrames:
    """The in-between animation: one RGBA frame per output time."""

    times: np.ndarray  # (T,) float64
    alphas: np.ndarray  # (T,) float64 alpha taken at each time
    frames: np.ndarray  # (T, H, W, 4) float32 straight alpha
    blend: str  # "optimal" | "diagonal"
