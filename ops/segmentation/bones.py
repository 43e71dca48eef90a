"""Bone geometry on a keyframe: distances to bone segments, body radii and per-bone body regions (§4.1)."""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from ops.geometry.polygon import project_to_segment
from ops.types import Skeleton


def segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(...,) float64 distance, pixels, from (..., 2) points to the segment a-b ((2,) each)."""
    return project_to_segment(points, a, b)[1]


def moved_with_bones(points: np.ndarray, bones: np.ndarray, bones_there: np.ndarray) -> np.ndarray:
    """(..., n, 2) pixels: (n, 2) points each moved rigidly with its (n, 2, 2) bone (parent end, child end) to that
    bone's (..., n, 2, 2) place: a point keeps its fraction along the bone and its offset across it, turned as the
    bone turns (a bone that changes length stretches the fraction, not the offset; a bone of no length turns by 0)."""
    p = np.asarray(points, np.float64)
    a, d = bones[:, 0], bones[:, 1] - bones[:, 0]
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-12), 0.0, 1.0)
    off = p - (a + t[:, None] * d)
    a2, d2 = bones_there[..., 0, :], bones_there[..., 1, :] - bones_there[..., 0, :]
    turn = np.arctan2(d2[..., 1], d2[..., 0]) - np.arctan2(d[:, 1], d[:, 0])
    c, s = np.cos(turn), np.sin(turn)
    rotated = np.stack([c * off[:, 0] - s * off[:, 1], s * off[:, 0] + c * off[:, 1]], axis=-1)
    return a2 + t[:, None] * d2 + rotated


def joined_bones(pose: np.ndarray, skeleton: Skeleton, tol: float = 1.0) -> np.ndarray:
    """(B, B) bool: bones that share a joint, or meet at the two ends of a bone shorter than `tol` px at the
    (J, >=2) pose: AnimatedDrawings' root - hip has no length, so the pelvis (from root) and the spine (from hip)
    meet there as at a joint, not as one part over another. Only through one such bone: both thighs of a side
    view hang from hips that project onto the root, and they stay two parts that can cross."""
    adjacent = skeleton.adjacent_bones()
    ends = np.asarray(pose, np.float64)[skeleton.bones][:, :, :2]  # (B, 2, 2)
    short = np.flatnonzero(np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1) < tol)
    joined = adjacent.copy()
    for z in short:
        joined |= adjacent[:, z][:, None] & adjacent[z][None, :]
    return joined


def _bone_ends(pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(B, 2, 2) float64 bone segment end points (parent, child) x (x, y), pixels."""
    return pose[:, :2].astype(np.float64)[skeleton.bones]


def _segment_distance_box(shape: tuple[int, int], a: np.ndarray, b: np.ndarray, reach: float):
    """Distance, pixels, from the pixels of a box around segment a-b (padded by reach) to it: (rows, cols, (h, w))."""
    lo = np.floor(np.minimum(a, b) - reach).astype(int)
    hi = np.ceil(np.maximum(a, b) + reach).astype(int) + 1
    c0, r0 = np.maximum(lo, 0)
    c1, r1 = min(hi[0], shape[1]), min(hi[1], shape[0])
    if c0 >= c1 or r0 >= r1:
        return slice(0, 0), slice(0, 0), np.zeros((0, 0))
    ys, xs = np.mgrid[r0:r1, c0:c1]
    pts = np.stack([xs, ys], axis=-1).astype(np.float64)
    return slice(r0, r1), slice(c0, c1), segment_distance(pts, a, b)


def bone_radii(
    foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton, samples: int = 32, quantile: float = 0.3
) -> np.ndarray:
    """(B,) float64 estimated body radius of each bone, pixels: a low quantile of the inscribed radius along its middle 80%.

    A low quantile (not the max) so that a limb crossing a thicker body part reads its own thickness from
    the part of the bone lying outside the body (the distance transform there is the limb's half-width).
    """
    dt = ndimage.distance_transform_edt(foreground)
    h, w = foreground.shape
    xy = pose[:, :2].astype(np.float64)
    t = np.linspace(0.1, 0.9, samples)
    radii = np.empty(len(skeleton.bones))
    for i, (p, c) in enumerate(skeleton.bones):
        pts = xy[p] + t[:, None] * (xy[c] - xy[p])
        col = np.clip(np.round(pts[:, 0]).astype(int), 0, w - 1)
        row = np.clip(np.round(pts[:, 1]).astype(int), 0, h - 1)
        radii[i] = float(np.quantile(dt[row, col], quantile))
    return np.maximum(radii, 1.0)


def thick_regions(
    foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton, margin_px: float = 1.5
) -> np.ndarray:
    """(B, H, W) bool per-bone body region: foreground pixels within the bone's radius (+ margin) of its segment.

    These regions overlap where bodies overlap, which is what the occlusion predictor needs.
    """
    radii = bone_radii(foreground, pose, skeleton) + margin_px
    out = np.zeros((len(radii),) + foreground.shape, bool)
    for i, ((a, b), r) in enumerate(zip(_bone_ends(pose, skeleton), radii)):
        rows, cols, dist = _segment_distance_box(foreground.shape, a, b, r)
        out[i, rows, cols] = (dist <= r) & foreground[rows, cols]
    return out


def bone_regions(
    foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton, reach: float = 1.6
) -> np.ndarray:
    """(B, H, W) bool disjoint per-bone body regions: foreground pixels nearest to that bone's segment.

    Voronoi by point-segment distance, limited to `reach` x the bone's radius (bone_radii) so that a
    bone does not claim distant parts of the silhouette. Use thick_regions for overlapping regions.
    """
    radii = reach * bone_radii(foreground, pose, skeleton)
    best = np.full(foreground.shape, np.inf)
    owner = np.full(foreground.shape, -1, np.int64)
    whole = float(sum(foreground.shape))  # a box padded by this covers the image
    for i, (a, b) in enumerate(_bone_ends(pose, skeleton)):
        rows, cols, dist = _segment_distance_box(foreground.shape, a, b, whole)
        closer = dist < best[rows, cols]
        best[rows, cols] = np.where(closer, dist, best[rows, cols])
        owner[rows, cols] = np.where(closer, i, owner[rows, cols])
    within = best <= radii[np.maximum(owner, 0)]
    own = owner[None] == np.arange(len(radii))[:, None, None]
    return own & (within & foreground)[None]


def bone_depths(pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(B,) float64 mean joint z of each bone (larger = farther)."""
    return pose[skeleton.bones, 2].mean(axis=1)


def bone_capsules(shape: tuple[int, int], pose: np.ndarray, skeleton: Skeleton, radii) -> np.ndarray:
    """(H, W) bool pixels within radii ((B,) or one float, pixels) of any bone segment; a zero-length bone is a disc.

    Rasterised with OpenCV's round-capped thick lines: exact to within a pixel, far cheaper than distances.
    """
    r = np.broadcast_to(np.asarray(radii, np.float64), (len(skeleton.bones),))
    out = np.zeros(shape, np.uint8)
    shift = 4  # sub-pixel end points
    for (a, b), ri in zip(_bone_ends(pose, skeleton), r):
        pa, pb = (tuple(int(v) for v in np.round(p * (1 << shift))) for p in (a, b))
        cv2.line(out, pa, pb, 1, thickness=max(1, int(round(2 * ri))), lineType=cv2.LINE_8, shift=shift)
    return out > 0


def bone_samples(pose: np.ndarray, skeleton: Skeleton, step: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Points along every bone about `step` pixels apart: (n, 2) float64 (x, y) pixels and (n,) int64 bone index."""
    points, owner = [], []
    for i, (a, b) in enumerate(_bone_ends(pose, skeleton)):
        k = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
        t = np.linspace(0.0, 1.0, k)[:, None]
        points.append(a + t * (b - a))
        owner.append(np.full(k, i, np.int64))
    if not points:
        return np.zeros((0, 2)), np.zeros(0, np.int64)
    return np.concatenate(points), np.concatenate(owner)
