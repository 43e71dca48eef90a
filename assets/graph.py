"""The asset graph of DESIGN.md as data: every asset key and its parents.

One lane per keyframe; `key{k}/...` never reads `key{1-k}/...` except where
the method needs the other keyframe (its pose as the topology target, its
drawing and refined masks for texturing).

Two deliberate narrowings of DESIGN.md's table, so edits recompute less:
the template reads both key poses instead of the whole motion (only the
other keyframe's pose is its target, §4.4), and it reads the T-junctions
through the refined masks, which carry them snapped onto the boundaries.
"""
from __future__ import annotations

SOURCES = ("key0/drawing", "key0/pose", "key0/t_junctions", "key1/drawing", "key1/pose", "key1/t_junctions", "motion",
           "ground_truth")


def _lane(k: int) -> dict[str, tuple[str, ...]]:
    o = 1 - k
    return {
        f"key{k}/masks": (f"key{k}/drawing", f"key{k}/pose"),
        f"key{k}/refined_masks": (f"key{k}/masks", f"key{k}/t_junctions"),
        f"key{k}/template": (f"key{k}/refined_masks", f"key{k}/pose", f"key{o}/pose"),
        f"key{k}/textured_template": (f"key{k}/template", f"key{k}/refined_masks", f"key{k}/drawing", f"key{o}/drawing",
                                      f"key{o}/refined_masks", f"key{o}/pose"),
        f"key{k}/deformed_frames": (f"key{k}/textured_template", "motion"),
    }


PARENTS: dict[str, tuple[str, ...]] = {
    **_lane(0),
    **_lane(1),
    "rife_matrix": ("key0/deformed_frames", "key1/deformed_frames"),
    "quality_metrics": ("rife_matrix", "key0/deformed_frames", "key1/deformed_frames"),
    "optimal_path": ("quality_metrics",),
    "inbetween_frames": ("rife_matrix", "optimal_path"),
}

STAGES = tuple(PARENTS)  # topological order

# The evaluation group (issue 5): baselines and metrics against ground truth; `inbetween eval` runs it.
EVAL_PARENTS: dict[str, tuple[str, ...]] = {
    "evaluation/rife_direct": ("key0/drawing", "key1/drawing", "motion"),
    "evaluation/single_layer": ("key0/refined_masks", "key1/refined_masks", "key0/drawing", "key1/drawing",
                                "key0/pose", "key1/pose", "motion"),
    "evaluation/metrics": ("rife_matrix", "optimal_path", "evaluation/single_layer", "evaluation/rife_direct",
                           "key0/drawing", "key1/drawing", "ground_truth"),
}
EVAL_STAGES = tuple(EVAL_PARENTS)
ALL_PARENTS = {**PARENTS, **EVAL_PARENTS}


def descendants(keys: set[str], stages: tuple[str, ...] = STAGES) -> set[str]:
    """Every one of `stages` downstream of any of `keys` (not including them)."""
    out: set[str] = set()
    for stage in stages:
        if any(p in keys or p in out for p in ALL_PARENTS[stage]):
            out.add(stage)
    return out
