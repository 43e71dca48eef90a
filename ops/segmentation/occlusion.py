"""Occlusion masks predicted from the skeleton (§4.1).

Occlusion: the paper predicts occlusion masks with a network whose weights
and training set are not public. This module stands in for it with a
skeleton-driven heuristic: every bone gets a "thick" body region (foreground
pixels within the bone's estimated radius of its segment, the radius read off
the foreground's distance transform along the bone); where the thick regions
of two bones that are NOT adjacent in the hierarchy overlap, the nearer bone
(smaller mean joint z) is taken to be in front, and the overlap is an
occlusion region. Limits, stated plainly:
- it only sees occlusions the skeleton implies: a sleeve over a hand, hair
  over a face, a prop, or a limb whose bone does not reach the overlap are
  invisible to it;
- it assumes limbs roughly as thick as the distance transform says: a limb
  drawn entirely over the body (no part of it outside the torso) reads the
  torso's thickness and its region is too large;
- bones joined through one intermediate bone (a clavicle between spine and
  upper arm) are non-adjacent but meet around that bone: the intermediate
  bone's thick region is removed from their overlap, which also hides a real
  occlusion lying right on it (a hand folded back onto its own upper arm);
  longer chains meeting at a joint can still yield a spurious region there;
- equal depths give no front/back order and are skipped with a warning.
Manual masks override the prediction, and the T-junction refinement
(ops/refine.py) corrects the region boundaries where the user clicked.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from ops.segmentation.bones import bone_depths, joined_bones, thick_regions
from ops.types import Skeleton
from ops.warning_subject import about, inside_point

MIN_REGION_FRACTION = 0.002  # occlusion components smaller than this share of the foreground are noise

def _bone_name(skeleton: Skeleton, b: int) -> str:
    """Readable name of bone b, e.g. 'elbow-hand'."""
    p, c = skeleton.bones[b]
    return f"{skeleton.joints[p]}-{skeleton.joints[c]}"


def _pair_overlaps(thick: np.ndarray, depth: np.ndarray, skeleton: Skeleton, min_px: float = 0.0,
                   joined: np.ndarray | None = None) -> tuple[list, list[str]]:
    """Overlaps of non-adjacent bones' (B, H, W) thick regions: list of (front, back, (H, W) bool), warnings.
    joined: (B, B) bool bones that meet at a joint or through a bone of no length (bones.joined_bones): at equal
    depth their overlap is where they meet, not worth a warning (AnimatedDrawings' pelvis and spine, on every
    key); at different depths it stays a region (a side view's near hip over the body).

    An overlap of two bones at equal depth is a warning only from min_px pixels on: a smaller one would have been
    dropped as noise had the bones had an order (the few pixels where a hip bone and the spine, joined through a
    bone of no length, meet round their shared joint)."""
    out, warnings = [], []
    adjacent = skeleton.adjacent_bones()
    joined = adjacent if joined is None else joined
    nb = thick.shape[0]
    for i in range(nb):
        for j in range(i + 1, nb):
            if adjacent[i, j]:
                continue
            overlap = thick[i] & thick[j]
            # bones joined through one short bone (spine - clavicle - upper arm) meet around it:
            # that is a joint, not an occlusion
            between = adjacent[i] & adjacent[j]
            if between.any():
                overlap &= ~thick[between].any(axis=0)
            if not overlap.any():
                continue
            if np.isclose(depth[i], depth[j]):
                if overlap.sum() < min_px or joined[i, j]:
                    continue
                warnings.append(about(
                    "bones", f"bodies overlap on {int(overlap.sum())} px but the bones have equal depth, so no "
                    "occlusion was predicted there", name=(_bone_name(skeleton, i), _bone_name(skeleton, j)),
                    at=inside_point(overlap), fix="give the joints different z or paint an occlusion mask"))
                continue
            front, back = (i, j) if depth[i] < depth[j] else (j, i)
            out.append((front, back, overlap))
    return out, warnings


def _region_front_bones(region: np.ndarray, pairs: list, thick: np.ndarray, adjacent: np.ndarray) -> tuple[int, np.ndarray]:
    """Main front bone and (b,) int64 front bones of one region, from the pairs overlapping it.

    A bone is in front where it is the nearer of a pair and behind where it is the farther. It is a front bone
    of the region when it is in front on more of the region's pixels than behind, so a region where an arm
    covers the belly and the near thigh covers the far one keeps both the arm and the near thigh in front.
    A neighbour of the main bone that is behind on no pixel joins when its body covers a tenth of the region.
    """
    front_px: dict[int, int] = {}
    back_px: dict[int, int] = {}
    for front, back, overlap in pairs:
        n = int((overlap & region).sum())
        if n:
            front_px[front] = front_px.get(front, 0) + n
            back_px[back] = back_px.get(back, 0) + n
    main = max(front_px, key=front_px.get)
    voted = [b for b, n in front_px.items() if n > back_px.get(b, 0)]
    area = int(region.sum())
    extra = [
        b
        for b in np.nonzero(adjacent[main])[0]
        if b != main and b not in back_px and (thick[b] & region).sum() >= 0.1 * area
    ]
    return main, np.array(sorted({main, *voted, *map(int, extra)}), np.int64)


def predict_occlusion(
    foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    """Predicted occlusion regions ((H, W) bool each, back to front), their (b,) int64 front bones, warnings."""
    thick = thick_regions(foreground, pose, skeleton)
    depth = bone_depths(pose, skeleton)
    adjacent = skeleton.adjacent_bones()
    min_area = MIN_REGION_FRACTION * max(int(foreground.sum()), 1)
    pairs, warnings = _pair_overlaps(thick, depth, skeleton, min_area, joined_bones(pose, skeleton))
    union = np.zeros_like(foreground, dtype=bool)
    for _, _, overlap in pairs:
        union |= overlap
    labels, n = ndimage.label(union, structure=np.ones((3, 3), bool))
    regions, fronts, keys, dropped = [], [], [], 0
    for lab in range(1, n + 1):
        region = labels == lab
        if region.sum() < min_area:
            dropped += 1
            continue
        main, front = _region_front_bones(region, pairs, thick, adjacent)
        regions.append(region)
        fronts.append(front)
        keys.append(-depth[main])  # larger z (farther) first: back to front
    if dropped:
        warnings.append(
            f"dropped {dropped} predicted occlusion component(s) smaller than "
            f"{MIN_REGION_FRACTION:.1%} of the foreground ({min_area:.0f} px)"
        )
    order = np.argsort(np.array(keys), kind="stable")
    return [regions[i] for i in order], [fronts[i] for i in order], warnings
