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
        f"key{k}/refined_masks": (f"key{k}/masks", f"key{k}/t_junctions", f"key{k}/pose", f"key{o}/pose"),
        f"key{k}/template": (f"key{k}/refined_masks", f"key{k}/pose", f"key{o}/pose"),
        f"key{k}/textured_template": (f"key{k}/template", f"key{k}/refined_masks", f"key{o}/refined_masks",
                                      f"key{k}/pose", f"key{o}/pose"),
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



def topological(parents: dict[str, tuple[str, ...]]) -> tuple[str, ...]:
    """Stages ordered so that each comes after all of its parents (ties keep the table's order).

    The table is not in that order: key0's texture reads key1's refined masks.
    """
    done: list[str] = []
    while len(done) < len(parents):
        ready = [n for n in parents if n not in done and all(p in done or p not in parents for p in parents[n])]
        if not ready:
            raise ValueError(f"the stage graph has a cycle among {sorted(set(parents) - set(done))}")
        done.append(ready[0])
    return tuple(done)


STAGES = topological(PARENTS)

# The evaluation group (issue 5): baselines and metrics against ground truth; `inbetween eval` runs it.
EVAL_PARENTS: dict[str, tuple[str, ...]] = {
    "evaluation/rife_direct": ("key0/drawing", "key1/drawing", "motion"),
    "evaluation/single_layer": ("key0/refined_masks", "key1/refined_masks",
                                "key0/pose", "key1/pose", "motion"),
    "evaluation/metrics": ("rife_matrix", "optimal_path", "evaluation/single_layer", "evaluation/rife_direct",
                           "key0/deformed_frames", "key1/deformed_frames", "key0/masks", "key1/masks",
                           "key0/drawing", "key1/drawing", "ground_truth"),
}
ALL_PARENTS = {**PARENTS, **EVAL_PARENTS}
ALL_STAGES = topological(ALL_PARENTS)
EVAL_STAGES = tuple(n for n in ALL_STAGES if n in EVAL_PARENTS)

