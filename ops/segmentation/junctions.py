"""T-junction clicks assigned to occlusion regions (§4.1). A click is never dropped silently.

The user's clicks are trusted more than the predicted regions: repeated
clicks are merged, a click just off the drawing is moved onto it, and each
goes to the region whose boundary is nearest. A click far from every region
grows the nearest region to meet it (a bridge along the foreground from the
region to the click); with no region at all, a region is started at the
click, inside the nearest occluding (nearest-to-the-viewer) bone's body,
with the click on its boundary. Only a click that lies far off the drawing is
left out, with a warning.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ops.geometry.snap import snap_into
from ops.segmentation.bones import bone_depths, bone_radii, segment_distance
from ops.types import Skeleton
from ops.warning_subject import about

MERGE_CLICKS_PX = 4.0  # clicks this close are one junction clicked several times
ASSOCIATE_PX = 12.0  # a click this close to a region's boundary belongs to that region as it is
OFF_DRAWING_PX = 36.0  # a click farther than this outside the character is not about it: left out, with a warning
BRIDGE_RADIUS_PX = 2.0  # half-width of the strip that grows a region out to a far click


def merge_clicks(points: np.ndarray, radius: float = MERGE_CLICKS_PX) -> tuple[np.ndarray, list[str]]:
    """(k', 2) float64 cluster means of (k, 2) clicks chained within `radius` pixels; warnings."""
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    if len(pts) < 2:
        return pts, []
    pairs = np.array(sorted(cKDTree(pts).query_pairs(radius)), np.int64).reshape(-1, 2)
    if len(pairs) == 0:
        return pts, []
    A = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(pts), len(pts)))
    n, lab = connected_components(A, directed=False)
    counts = np.bincount(lab, minlength=n)
    merged = np.stack([np.bincount(lab, pts[:, d], n) for d in (0, 1)], axis=1) / counts[:, None]
    warnings = [about("T-junction", f"{int(c)} clicks within {radius:g} px merged into one", at=(x, y))
                for c, (x, y) in zip(counts, merged) if c > 1]
    return merged, warnings


def boundary_distance(mask: np.ndarray) -> np.ndarray:
    """(H, W) float64 distance, pixels, to the nearest boundary pixel of a (H, W) bool mask."""
    inner = mask & ~ndimage.binary_erosion(mask, border_value=0)
    return ndimage.distance_transform_edt(~inner)


def _capsule(shape: tuple[int, int], a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
    """(H, W) bool pixels within `radius` of the segment a-b ((2,) pixels each)."""
    img = np.zeros(shape, np.uint8)
    pa, pb = (tuple(int(round(v * 16)) for v in p) for p in (a, b))
    cv2.line(img, pa, pb, 1, thickness=max(1, int(round(2 * radius))), lineType=cv2.LINE_8, shift=4)
    return img.astype(bool)


def grow_to(region: np.ndarray, point: np.ndarray, foreground: np.ndarray) -> np.ndarray:
    """(H, W) bool region grown by a strip from its nearest pixel to `point` (2,), inside the foreground."""
    ys, xs = np.nonzero(region)
    k = int(np.argmin((xs - point[0]) ** 2 + (ys - point[1]) ** 2))
    strip = _capsule(region.shape, np.array([xs[k], ys[k]], float), point, BRIDGE_RADIUS_PX)
    return region | (strip & foreground)


def start_region(point: np.ndarray, foreground: np.ndarray, pose: np.ndarray,
                 skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray]:
    """A new region at a click (2,): (H, W) bool disc inside the nearest front bone's body, the click on its rim,
    and its (b,) int64 front bones. The front bone is the nearest to the viewer among the bones whose bodies
    reach the click."""
    xy = np.asarray(pose, np.float64)[:, :2]
    radii = bone_radii(foreground, pose, skeleton)
    dist = np.array([segment_distance(point, xy[p], xy[c]) for p, c in skeleton.bones])
    near = np.nonzero(dist <= 1.5 * radii + ASSOCIATE_PX)[0]
    near = near if len(near) else np.array([int(np.argmin(dist))])
    front = int(near[np.argmin(bone_depths(pose, skeleton)[near])])
    p, c = skeleton.bones[front]
    d, e = xy[c] - xy[p], point - xy[p]
    t = np.clip((e @ d) / max(float(d @ d), 1e-12), 0.0, 1.0)
    foot = xy[p] + t * d  # the nearest point of the front bone: the region lies from the click towards it
    r = float(np.clip(radii[front], 3.0, 4.0 * ASSOCIATE_PX))
    towards = foot - point
    n = np.linalg.norm(towards)
    centre = point + (towards / n * r if n > 1e-9 else np.zeros(2))
    yy, xx = np.mgrid[0:foreground.shape[0], 0:foreground.shape[1]]
    disc = (xx - centre[0]) ** 2 + (yy - centre[1]) ** 2 <= r * r
    return disc & foreground, np.array([front], np.int64)


def assign_junctions(points: np.ndarray, regions: list[np.ndarray], front_bones: list[np.ndarray],
                     foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton, tol: float = ASSOCIATE_PX):
    """Clicks (k, 2) pixels -> (regions, front bones, per-region junctions (k_r, 2) float64, warnings).

    Regions ((H, W) bool each) are grown or started so that every click within OFF_DRAWING_PX of the
    character belongs to one; junctions are not moved onto regions: the regions are moved onto them
    (ops.segmentation.refine).
    """
    pts, warnings = merge_clicks(points)
    regions, front_bones = [np.asarray(r, bool).copy() for r in regions], list(front_bones)
    per_region: list[list] = [[] for _ in regions]
    fields: dict[int, np.ndarray] = {}  # region -> its boundary_distance, until the region changes

    def distance(i: int, r: int, c: int) -> float:
        """Pixels from (row r, column c) to region i's boundary; inf for an empty region."""
        if not regions[i].any():
            return np.inf
        if i not in fields:  # one distance transform per region, not one per click (cost linear in the clicks)
            fields[i] = boundary_distance(regions[i])
        return float(fields[i][r, c])

    snapped, moved = snap_into(foreground, pts) if len(pts) else (pts, np.zeros(0, bool))
    for i, (q, orig) in enumerate(zip(snapped, pts)):
        x, y = orig
        shift = float(np.linalg.norm(q - orig))
        if moved[i] and shift > OFF_DRAWING_PX:
            warnings.append(about("T-junction", f"is {shift:.1f} px off the drawing; left out", at=(x, y),
                                  fix="click where an outline meets another"))
            continue
        if moved[i] and shift > 0:
            warnings.append(about("T-junction", f"was {shift:.1f} px outside the drawing; moved onto it", at=(x, y)))
        c, r = int(round(q[0])), int(round(q[1]))
        dist = [distance(i, r, c) for i in range(len(regions))]
        owner = int(np.argmin(dist)) if regions else -1
        if owner >= 0 and dist[owner] > tol and regions[owner][r, c]:
            warnings.append(about("T-junction", f"lies {dist[owner]:.1f} px inside occlusion region {owner}; "
                                  "its boundary is moved through it", at=(x, y)))
        elif owner >= 0 and dist[owner] > tol:
            regions[owner] = grow_to(regions[owner], q, foreground)
            fields.pop(owner, None)
            warnings.append(about("T-junction", f"was {dist[owner]:.1f} px from every occlusion region; "
                                  f"region {owner} grown to meet it", at=(x, y)))
        elif owner < 0:
            region, front = start_region(q, foreground, pose, skeleton)
            regions.append(region)
            front_bones.append(front)
            per_region.append([])
            owner = len(regions) - 1
            b = skeleton.bones[front[0]]
            warnings.append(about("T-junction", "had no occlusion region; a region was started there in front of "
                                  f"it on bone {skeleton.joints[b[0]]}-{skeleton.joints[b[1]]}", at=(x, y)))
        per_region[owner].append(q)
    return regions, front_bones, [np.asarray(j, np.float64).reshape(-1, 2) for j in per_region], warnings
