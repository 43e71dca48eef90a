"""Foreground and occlusion masks of a keyframe drawing (§4.1).

Foreground: ink drawings on light paper. Luminance (alpha composited over
white), ink = local (adaptive) threshold confirmed by a global darkness test
against the paper level, morphological closing to seal small gaps in the
outline, hole filling (so an outlined character whose interior is paper-white
becomes a filled silhouette), largest connected component.

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

import cv2
import numpy as np
from scipy import ndimage

from ops.errors import ShotError
from ops.types import Masks, Skeleton

NEAR_OUTSIDE_PX = 4.0  # joints this close outside the foreground are "slightly" outside
MIN_REGION_FRACTION = 0.002  # occlusion components smaller than this share of the foreground are noise


# ---------------------------------------------------------------- foreground


def luminance(drawing: np.ndarray) -> np.ndarray:
    """(H, W) float32 luminance in [0, 1] of a (H, W, C) float32 drawing, alpha composited over white."""
    img = drawing if drawing.ndim == 3 else drawing[..., None]
    c = img.shape[2]
    color = img[..., :3] if c >= 3 else img[..., :1]
    lum = color @ np.array([0.299, 0.587, 0.114], np.float32) if color.shape[2] == 3 else color[..., 0]
    if c in (2, 4):
        alpha = img[..., -1]
        lum = lum * alpha + (1.0 - alpha)  # straight alpha over white paper
    return np.clip(lum, 0.0, 1.0).astype(np.float32)


def ink_mask(lum: np.ndarray) -> np.ndarray:
    """(H, W) bool ink pixels of a (H, W) luminance image: adaptive threshold confirmed by global darkness."""
    h, w = lum.shape
    block = max(15, (min(h, w) // 8) | 1)  # odd, a few line widths wide
    u8 = np.round(lum * 255).astype(np.uint8)
    local = cv2.adaptiveThreshold(u8, 1, cv2.ADAPTIVE_THRESH_GAUSSIAN_C, cv2.THRESH_BINARY_INV, block, 8) > 0
    # the paper level is the bright mode: tinted paper or vignetting must not read as ink
    paper = float(np.percentile(lum, 90))
    darker = lum < paper - 0.08
    # solid ink fills, where the local threshold only finds the edges; absolute too, so shaded paper is not ink
    very_dark = lum < min(paper - 0.35, 0.3)
    return (local & darker) | very_dark


def largest_component(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool: the largest 8-connected component of a (H, W) bool mask (empty stays empty)."""
    labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
    if n <= 1:
        return mask.astype(bool)
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    return labels == int(np.argmax(sizes))


def foreground_mask(drawing: np.ndarray, close_px: int | None = None) -> np.ndarray:
    """(H, W) bool filled character silhouette of a (H, W, C) float32 ink drawing on light paper."""
    lum = luminance(drawing)
    ink = ink_mask(lum)
    if drawing.ndim == 3 and drawing.shape[2] in (2, 4):
        opaque = drawing[..., -1] > 0.5
        if (~opaque).mean() > 0.01:  # a cut-out character on a transparent canvas is foreground too
            ink |= opaque
    h, w = lum.shape
    r = close_px if close_px is not None else max(3, int(round(0.01 * max(h, w))))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    # pad so closing near the frame border does not glue the character to the edge
    pad = r + 1
    padded = np.pad(ink.astype(np.uint8), pad)
    closed = cv2.morphologyEx(padded, cv2.MORPH_CLOSE, kernel)[pad:-pad, pad:-pad] > 0
    filled = ndimage.binary_fill_holes(closed)
    return largest_component(filled)


# ---------------------------------------------------------------- bone geometry


def segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(...,) float64 distance, pixels, from (..., 2) points to the segment a-b ((2,) each)."""
    d = b - a
    L2 = float(d @ d)
    if L2 < 1e-12:
        return np.linalg.norm(points - a, axis=-1)
    t = np.clip(((points - a) @ d) / L2, 0.0, 1.0)
    return np.linalg.norm(points - (a + t[..., None] * d), axis=-1)


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


# ---------------------------------------------------------------- occlusion prediction


def _bone_name(skeleton: Skeleton, b: int) -> str:
    """Readable name of bone b, e.g. 'elbow-hand'."""
    p, c = skeleton.bones[b]
    return f"{skeleton.joints[p]}-{skeleton.joints[c]}"


def _pair_overlaps(thick: np.ndarray, depth: np.ndarray, skeleton: Skeleton) -> tuple[list, list[str]]:
    """Overlaps of non-adjacent bones' (B, H, W) thick regions: list of (front, back, (H, W) bool), warnings."""
    out, ties = [], []
    adjacent = skeleton.adjacent_bones()
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
                ties.append(f"{_bone_name(skeleton, i)} / {_bone_name(skeleton, j)} ({int(overlap.sum())} px)")
                continue
            front, back = (i, j) if depth[i] < depth[j] else (j, i)
            out.append((front, back, overlap))
    warnings = []
    if ties:
        warnings.append(
            "bodies of non-adjacent bones overlap but the bones have equal depth, so no occlusion was "
            f"predicted there: {', '.join(ties)}; fix: give the joints different z or paint an occlusion mask"
        )
    return out, warnings


def _region_front_bones(region: np.ndarray, pairs: list, thick: np.ndarray, adjacent: np.ndarray) -> tuple[int, np.ndarray]:
    """Main front bone and (b,) int64 front bones of one region, from the pairs overlapping it."""
    votes: dict[int, int] = {}
    backs = set()
    for front, back, overlap in pairs:
        n = int((overlap & region).sum())
        if n:
            votes[front] = votes.get(front, 0) + n
            backs.add(back)
    main = max(votes, key=votes.get)
    area = int(region.sum())
    extra = [
        b
        for b in np.nonzero(adjacent[main])[0]
        if b != main and b not in backs and (thick[b] & region).sum() >= 0.1 * area
    ]
    return main, np.array(sorted({main, *map(int, extra)}), np.int64)


def predict_occlusion(
    foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    """Predicted occlusion regions ((H, W) bool each, back to front), their (b,) int64 front bones, warnings."""
    thick = thick_regions(foreground, pose, skeleton)
    depth = bone_depths(pose, skeleton)
    adjacent = skeleton.adjacent_bones()
    pairs, warnings = _pair_overlaps(thick, depth, skeleton)
    union = np.zeros_like(foreground, dtype=bool)
    for _, _, overlap in pairs:
        union |= overlap
    labels, n = ndimage.label(union, structure=np.ones((3, 3), bool))
    min_area = MIN_REGION_FRACTION * max(int(foreground.sum()), 1)
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


# ---------------------------------------------------------------- manual masks and checks


def snap_into(mask: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) float64 points moved to the nearest pixel of a (H, W) bool mask when outside it; (k,) bool moved."""
    if not mask.any():
        raise ValueError("snap_into: empty mask")
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    h, w = mask.shape
    col = np.clip(np.round(pts[:, 0]).astype(int), 0, w - 1)
    row = np.clip(np.round(pts[:, 1]).astype(int), 0, h - 1)
    inside = mask[row, col] & (col == np.round(pts[:, 0])) & (row == np.round(pts[:, 1]))
    _, (ir, ic) = ndimage.distance_transform_edt(~mask, return_indices=True)
    out = pts.copy()
    moved = ~inside
    out[moved, 0] = ic[row[moved], col[moved]]
    out[moved, 1] = ir[row[moved], col[moved]]
    return out, moved


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
            warnings.append(f"manual occlusion mask {r}: {outside} px outside the foreground clipped away")
        m = m & foreground
        if not m.any():
            warnings.append(
                f"manual occlusion mask {r} is empty inside the foreground and was dropped; "
                "fix: paint the region over the character"
            )
            continue
        kept.append(m)
    return kept, warnings


def pose_warnings(foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton) -> list[str]:
    """Warnings for joints and bone midpoints outside the (H, W) bool foreground (the template snaps them)."""
    dist_out = ndimage.distance_transform_edt(~foreground)
    h, w = foreground.shape
    xy = pose[:, :2]
    mids = xy[skeleton.bones].mean(axis=1)
    names = list(skeleton.joints) + [f"bone {skeleton.joints[p]}-{skeleton.joints[c]} midpoint" for p, c in skeleton.bones]
    warnings = []
    for name, (x, y) in zip(names, np.concatenate([xy, mids])):
        if not (0 <= x <= w - 1 and 0 <= y <= h - 1):
            warnings.append(f"{name} at ({x:.1f}, {y:.1f}) lies outside the image; check the pose")
            continue
        d = float(dist_out[int(round(y)), int(round(x))])
        if d == 0:
            continue
        how = "slightly" if d <= NEAR_OUTSIDE_PX else "far"
        warnings.append(f"{name} at ({x:.1f}, {y:.1f}) lies {how} outside the foreground ({d:.1f} px)")
    return warnings


def _foreground(drawing: np.ndarray, manual: np.ndarray | None, source: str) -> np.ndarray:
    """(H, W) bool foreground: the manual mask when given, else predicted; raises ShotError when empty."""
    if manual is None:
        fg = foreground_mask(drawing)
        if not fg.any():
            raise ShotError(source, "keyframes", "no ink found in the drawing", "draw on light paper or give masks.foreground")
        return fg
    m = np.asarray(manual)
    if m.shape != drawing.shape[:2]:
        raise ShotError(
            source, "masks.foreground", f"size {m.shape} differs from the drawing {drawing.shape[:2]}",
            "save the mask at the keyframe's width and height",
        )
    fg = m > 0.5 if m.dtype != bool else m.copy()
    if not fg.any():
        raise ShotError(source, "masks.foreground", "the manual foreground mask is empty", "paint the character white")
    return fg


def build_masks(
    drawing: np.ndarray,
    pose: np.ndarray,
    skeleton: Skeleton,
    manual_foreground: np.ndarray | None = None,
    manual_occlusion: list[np.ndarray] | None = None,
    source: str = "drawing",
) -> Masks:
    """Masks of a (H, W, C) float32 drawing at a (J, 3) pose; manual masks ((H, W) bool/float) override.

    manual_occlusion None or empty = predict (the shot format cannot say "no regions"); otherwise exactly
    those regions. `source` names the keyframe file in errors.
    """
    fg = _foreground(drawing, manual_foreground, source)
    warnings = pose_warnings(fg, pose, skeleton)
    predicted = manual_occlusion is None or len(manual_occlusion) == 0
    if predicted:
        regions, fronts, w = predict_occlusion(fg, pose, skeleton)
        warnings += w
    else:
        kept, w = clip_manual_occlusion(list(manual_occlusion), fg)
        warnings += w
        scored = []
        thick = thick_regions(fg, pose, skeleton) if kept else None
        for r in kept:
            front, depth, w = manual_front_bones(r, thick, pose, skeleton)
            warnings += w
            scored.append((-depth, r, front))
        scored.sort(key=lambda s: s[0])  # stable: ties keep the file order
        regions, fronts = [s[1] for s in scored], [s[2] for s in scored]
    n_manual = (manual_foreground is not None) + (not predicted)
    kind = {0: "predicted", 1: "mixed", 2: "manual"}[n_manual]
    return Masks(foreground=fg, occlusion=regions, front_bones=fronts, source=kind, warnings=warnings)
