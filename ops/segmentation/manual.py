"""Manual occlusion masks: clipped to the foreground, and their front bones read off the skeleton."""
from __future__ import annotations

import numpy as np

from ops.errors import ShotError
from ops.segmentation.bones import _bone_ends, bone_depths, segment_distance
from ops.types import Skeleton
from ops.warning_subject import about, inside_point


def manual_front_bones(
    region: np.ndarray, thick: np.ndarray, pose: np.ndarray, skeleton: Skeleton
) -> tuple[np.ndarray, float, list[str]]:
    """(b,) int64 front bones of a manual (H, W) bool region given the (B, H, W) thick_regions, its depth, warnings.

    The bones whose thick regions cover the region most (at least half the best cover) are candidates;
    the nearest candidate (min mean z) is in front, with its adjacent candidates.
    """
    depth = bone_depths(pose, skeleton)
    cover = (thick & region[None]).sum(axis=(1, 2))
    if cover.max() == 0:
        centre = np.argwhere(region).mean(axis=0)[::-1]
        dist = [segment_distance(centre, a, b) for a, b in _bone_ends(pose, skeleton)]
        main = int(np.argmin(dist))
        return np.array([main], np.int64), float(depth[main]), [
            f"manual occlusion region touches no bone's body; front bone = nearest bone {main} to its centre"
        ]
    cand = np.nonzero(cover >= 0.5 * cover.max())[0]
    main = int(cand[np.argmin(depth[cand])])
    adjacent = skeleton.adjacent_bones()[main]
    front = [int(b) for b in cand if adjacent[b] and depth[b] <= depth[main] + 1e-9]
    return np.array(sorted(set(front) | {main}), np.int64), float(depth[main]), []


def clip_manual_occlusion(
    manual: list[np.ndarray], foreground: np.ndarray
) -> tuple[list[np.ndarray], list[str]]:
    """Manual (H, W) occlusion masks clipped to the (H, W) bool foreground; empty ones dropped; warnings."""
    kept, warnings = [], []
    for r, m in enumerate(manual):
        m = np.asarray(m)
        if m.shape != foreground.shape:
            raise ShotError(
                f"occlusion mask {r}", "masks.occlusion", f"size {m.shape} differs from the drawing {foreground.shape}",
                "save the mask at the keyframe's width and height",
            )
        m = m > 0.5 if m.dtype != bool else m
        outside = int((m & ~foreground).sum())
        if outside:
            warnings.append(about("manual occlusion mask", f"{outside} px outside the foreground clipped away",
                                  name=r, at=inside_point(m & ~foreground)))
        at = inside_point(m)
        m = m & foreground
        if not m.any():
            warnings.append(about("manual occlusion mask", "is empty inside the foreground and was dropped", name=r,
                                  at=at, fix="paint the region over the character"))
            continue
        kept.append(m)
    return kept, warnings
