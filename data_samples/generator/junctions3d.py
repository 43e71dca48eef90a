"""T-junctions of a 3D sample, read off its depth buffer: where a covered body's outline ends against the outline
of the body that covers it (the 2D generator's definition, occlusion.t_junctions, made exact in depth).

Per pair of bones that share no joint and whose filled shapes overlap: the points where the two shapes'
outlines cross (each outline the 0.5 level of its shape smoothed by OUTLINE_SIGMA px, so pixel staircases do
not cross back and forth), where the drawing shows the T: near the point, the overlap shows one of the two
(the front; else a third body covers the point, as a part painted over a junction hides it in 2D) and the
back shows outside the front (its outline is seen to end there). Points of a pair closer than MERGE_PX are
one. The stem is the back bone's outline leaving the point outside the front's shape.
"""
from __future__ import annotations

import cv2
import numpy as np
from skimage.measure import find_contours

from .geometry import segment_crossings, stem_directions

OUTLINE_SIGMA = 1.0  # px: smoothing of a bone's shape before its outline is traced
MERGE_PX = 2.0  # crossings of one pair this close are one junction (the 2D generator's rule)
NEAR_PX = 4  # the overlap read around a junction for its front, px
VISIBLE_SHARE = 0.6  # the front and the back must show on this share of their pixels near a junction
STEM_PX = 6.0  # how far along the back outline its direction is read


def _outlines(field: np.ndarray, off: tuple[int, int]) -> list[np.ndarray]:
    """(n, 2) x, y polylines of a crop's 0.5 level, in image pixels (crop offset off = (y0, x0))."""
    return [c[:, ::-1] + (off[1], off[0]) for c in find_contours(field, 0.5) if len(c) >= 2]


def _crossings(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(k, 2) crossing points of two open polylines p (n, 2) and q (m, 2)."""
    a, b = p[:-1], p[1:]
    c, d = q[:-1], q[1:]
    lo = np.minimum(c, d).min(0) - 1
    hi = np.maximum(c, d).max(0) + 1
    near = np.all((np.maximum(a, b) >= lo) & (np.minimum(a, b) <= hi), axis=1)  # p's segments near q's box
    a, b = a[near], b[near]
    if not len(a):
        return np.zeros((0, 2))
    return segment_crossings(a, b, c, d)


def pair_junctions(a: int, b: int, cover: dict, near_bone: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) px T-junctions of bones a and b and (k, 2) unit stems, from their (H, W) bool shapes cover[.] and
    near_bone: (H, W) int64 the bone of the nearest surface at each pixel (-1: none; depth_order)."""
    both = cover[a] & cover[b]
    ys, xs = np.nonzero(both)
    h, w = both.shape
    pad = 6
    y0, y1 = max(int(ys.min()) - pad, 0), min(int(ys.max()) + pad + 1, h)
    x0, x1 = max(int(xs.min()) - pad, 0), min(int(xs.max()) + pad + 1, w)
    big = (slice(max(y0 - pad, 0), min(y1 + pad, h)), slice(max(x0 - pad, 0), min(x1 + pad, w)))
    off = (big[0].start, big[1].start)
    fields = {k: cv2.GaussianBlur(cover[k][big].astype(np.float32), (0, 0), OUTLINE_SIGMA) for k in (a, b)}
    lines = {k: _outlines(np.pad(f, 1, constant_values=0.0), (off[0] - 1, off[1] - 1)) for k, f in fields.items()}
    pts: list[np.ndarray] = []
    stems: list[np.ndarray] = []
    for la in lines[a]:
        for lb in lines[b]:
            for p in _crossings(la, lb):
                if not (x0 <= p[0] < x1 and y0 <= p[1] < y1):
                    continue  # the crop's own border
                if any(np.hypot(*(p - q)) < MERGE_PX for q in pts):
                    continue
                front, back = _front(a, b, p, cover, near_bone)
                if front is None:
                    continue
                line = lb if back == b else la
                f = fields[front]

                def outside(q: np.ndarray, f: np.ndarray = f) -> np.ndarray:  # less of the front's shape = farther out
                    i = np.clip(np.round(q[:, 1] - off[0]).astype(int), 0, f.shape[0] - 1)
                    j = np.clip(np.round(q[:, 0] - off[1]).astype(int), 0, f.shape[1] - 1)
                    return -f[i, j]
                pts.append(p)
                stems.append(stem_directions(line, p[None], outside, STEM_PX, closed=False)[0])
    return np.array(pts).reshape(-1, 2), np.array(stems).reshape(-1, 2)


def _front(a: int, b: int, p: np.ndarray, cover: dict, near_bone: np.ndarray) -> tuple[int | None, int | None]:
    """(front, back) at a crossing p of a's and b's outlines when the drawing shows a T there, else (None, None).

    Read on the pixels within NEAR_PX of p by the visible surface's bone: the front shows on at least
    VISIBLE_SHARE of the overlap (else a third body covers the crossing, or the two interpenetrate right at
    it), and the back shows on at least VISIBLE_SHARE of its shape outside the front (its outline, the stem,
    is seen leaving the junction; pixels of no surface, the outer half of a line, are not counted)."""
    h, w = near_bone.shape
    cy, cx = int(round(p[1])), int(round(p[0]))
    sl = (slice(max(cy - NEAR_PX, 0), min(cy + NEAR_PX + 1, h)), slice(max(cx - NEAR_PX, 0), min(cx + NEAR_PX + 1, w)))
    yy, xx = np.mgrid[sl]
    disc = (yy - p[1]) ** 2 + (xx - p[0]) ** 2 <= NEAR_PX**2
    owner = near_bone[sl][disc]
    ca, cb = cover[a][sl][disc], cover[b][sl][disc]
    both = ca & cb
    if both.sum() < 2:
        return None, None
    front, back = (a, b) if (owner[both] == a).sum() >= (owner[both] == b).sum() else (b, a)
    if (owner[both] == front).mean() < VISIBLE_SHARE:
        return None, None
    stem = (cb if back == b else ca) & ~both & (owner >= 0)
    if stem.sum() < 2 or (owner[stem] == back).mean() < VISIBLE_SHARE:
        return None, None
    return front, back


def depth_order(entry: dict, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) float32 depth of the nearest surface (inf: paper) and (H, W) int64 its bone (-1: paper)."""
    nearest = np.full(shape, np.inf, np.float32)
    bone = np.full(shape, -1, np.int64)
    for k, e in entry.items():
        closer = e < nearest
        nearest[closer] = e[closer]
        bone[closer] = k
    return nearest, bone
