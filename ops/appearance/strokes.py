"""Ink strokes that run into a hole of the pocket texture, paired across it and continued as smooth curves (§5.1).

A cartoon's hidden part is flat colour divided by ink lines. Where a line of the visible drawing runs into
the hole (a belly's outline under the arm that covers it, the edge of a belly patch), its end is found on the
hole's boundary: a thin dark structure (L* below its neighbourhood's closing) whose centre line (the
skeleton) points into the hole. Lines that run along the boundary instead (the covering part's own outline,
which is what bounds a pocket) are not continued. Ends are paired by position, direction, width and colour,
and each pair is joined by a cubic Hermite curve that leaves and enters along the strokes' directions; an
end without a partner is not continued (the hidden line may end, or leave where nothing shows it).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree
from skimage.morphology import skeletonize

INK_CONTRAST_L = 10.0  # L* units: a line is this much darker than the closing of its neighbourhood
INK_MAX_WIDTH_PX = 5  # half the widest stroke taken for a line (the closing's disc radius); wider dark areas are fills
RADIAL_COS = 0.5  # a stroke enters the hole when it runs within 60 deg of the boundary's normal
DIRECTION_RADIUS_PX = 3.0  # skeleton neighbours within this radius give a pixel's direction
MIN_RADIAL_EXTENT_PX = 3.0  # a stroke end reaches at least this far out from the hole (shorter: a blob, a spur)
TOUCH_PX = 2.0  # a stroke ends on the hole when its centre line comes within half its width plus this
FIT_CLEAR_PX = 1.5  # a stroke's axis is fitted on its skeleton farther than half its width plus this from the hole
PAIR_MAX_ANGLE_COS = 0.64  # each end's direction within ~50 deg of the chord joining the two ends
PAIR_MAX_DE = 15.0  # paired ends have ink colours within this CIE76 distance
PAIR_MAX_WIDTH_RATIO = 2.0  # and widths within this ratio
PAIR_MIN_INSIDE = 0.8  # the curve between them runs inside the hole for at least this share of its length
AMBIGUOUS_MARGIN = 0.15  # a second partner whose cost is within this of the best makes the pairing ambiguous


@dataclass
class StrokeEnd:
    """Where one ink stroke of the surroundings meets a hole."""

    point: np.ndarray  # (2,) float64 x, y pixels: the stroke's centre line where it reaches the hole
    direction: np.ndarray  # (2,) float64 unit, pointing into the hole
    width: float  # pixels, the drawn stroke's width
    colour: np.ndarray  # (3,) float32 RGB [0, 1] of the stroke's centre
    pixels: np.ndarray  # (s, 2) int64 (y, x) skeleton pixels of the stroke outside the hole


@dataclass
class StrokePair:
    """Two stroke ends joined across a hole."""

    a: int  # index of the first end
    b: int  # index of the second end
    cost: float  # 0 = both ends point straight at each other
    curve: np.ndarray  # (n, 2) float64 x, y pixels, from end a to end b
    ambiguous: bool  # another partner was almost as good for one of the two ends


def lab(image: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32 RGB [0, 1] -> (H, W, 3) float32 CIE Lab (L* 0-100)."""
    return cv2.cvtColor(np.clip(np.asarray(image, np.float32), 0.0, 1.0), cv2.COLOR_RGB2Lab)


def ink_mask(L: np.ndarray, solid: np.ndarray, max_width: int = INK_MAX_WIDTH_PX,
             contrast: float = INK_CONTRAST_L) -> np.ndarray:
    """(H, W) bool lines: pixels of `solid` (H, W) bool whose L* (H, W) float32 lies `contrast` below the morphological
    closing over a disc of radius max_width (a black-hat). Off `solid` counts as white, so an outline against
    the paper (or against a hole) is a line too."""
    bright = np.where(solid, L, 100.0).astype(np.float32)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * max_width + 1, 2 * max_width + 1))
    blackhat = cv2.morphologyEx(bright, cv2.MORPH_BLACKHAT, disc, borderType=cv2.BORDER_REPLICATE)
    return (blackhat >= contrast) & solid


def _directions(pts: np.ndarray, radius: float = DIRECTION_RADIUS_PX) -> np.ndarray:
    """(s, 2) float64 unit principal direction (x, y) of the skeleton pixels (s, 2) (y, x) around each one."""
    tree = cKDTree(pts)
    out = np.zeros((len(pts), 2))
    for i, nb in enumerate(tree.query_ball_point(pts, radius)):
        q = pts[nb][:, ::-1].astype(np.float64)
        q -= q.mean(axis=0)
        w, v = np.linalg.eigh(q.T @ q)
        out[i] = v[:, 1] if w[1] > 0 else (1.0, 0.0)
    return out


def _sample(field: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(k,) bilinear samples of a (H, W) field at points (k, 2) x, y pixels (nearest edge value outside)."""
    return ndimage.map_coordinates(field, [xy[:, 1], xy[:, 0]], order=1, mode="nearest")


def entering_strokes(image: np.ndarray, ink: np.ndarray, hole: np.ndarray, outside: np.ndarray,
                     reach: float) -> list[StrokeEnd]:
    """The strokes of the (H, W) bool `ink` outside `hole` (H, W) bool, within `reach` px of it, that run into it.

    image (H, W, 3) float32 RGB gives the ink's colour; `outside` (H, W) float64 is each pixel's distance to the
    hole (0 inside). A skeleton pixel is radial when its direction lies within 60 deg of the hole's normal there
    (the gradient of `outside`); each 8-connected run of radial pixels that comes within half its width plus
    TOUCH_PX of the hole and spans at least MIN_RADIAL_EXTENT_PX of distance is a stroke end. Its direction is
    the run's principal axis, its point where that axis enters the hole.
    """
    near = ink & ~hole & (outside <= reach)
    skel = skeletonize(near)
    ys, xs = np.nonzero(skel)
    if len(ys) < 2:
        return []
    pts = np.stack([ys, xs], axis=1)
    d = _directions(pts)
    gy, gx = np.gradient(ndimage.gaussian_filter(outside, 1.0))
    normal = np.stack([gx[ys, xs], gy[ys, xs]], axis=1)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-9)
    radial = np.abs((d * normal).sum(axis=1)) >= RADIAL_COS
    grid = np.zeros(hole.shape, bool)
    grid[ys[radial], xs[radial]] = True
    runs, n = ndimage.label(grid, structure=np.ones((3, 3), bool))
    half = ndimage.distance_transform_edt(ink)  # at a line's centre: its half width plus half a pixel
    signed = outside - ndimage.distance_transform_edt(hole)  # > 0 outside the hole, <= 0 inside
    ends = []
    for r in range(1, n + 1):
        ry, rx = np.nonzero(runs == r)
        dist = outside[ry, rx]
        width = max(1.0, 2.0 * float(np.median(half[ry, rx])) - 1.0)
        if dist.min() > width / 2 + TOUCH_PX or dist.max() - dist.min() < MIN_RADIAL_EXTENT_PX:
            continue
        axis, centre, width = _stroke_axis(runs == r, near, outside, width)
        inward = -np.array([gx[ry, rx].mean(), gy[ry, rx].mean()])
        if axis @ inward < 0:
            axis = -axis
        steps = centre + np.arange(0.0, 3.0 * reach, 0.5)[:, None] * axis
        inside = np.nonzero(_sample(signed, steps) <= 0.0)[0]
        if not len(inside):
            continue  # the stroke points past the hole
        colour = np.median(image[ry, rx], axis=0).astype(np.float32)
        ends.append(StrokeEnd(steps[inside[0]], axis, width, colour, np.stack([ry, rx], axis=1).astype(np.int64)))
    return ends


def _principal(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unit principal axis (2,), centroid (2,)) of points q (k, 2)."""
    c = q.mean(axis=0)
    _, v = np.linalg.eigh((q - c).T @ (q - c))
    return v[:, 1], c


def _stroke_axis(run: np.ndarray, ink: np.ndarray, outside: np.ndarray, width: float
                 ) -> tuple[np.ndarray, np.ndarray, float]:
    """(unit axis (2,) x, y, a point on it (2,), width px) of the stroke whose skeleton is the (H, W) bool `run`
    and whose width is about `width` (from its distance transform).

    Fitted on the stroke's own ink pixels (the skeleton staircases and bends at its ends) away from the hole,
    which cuts the stroke off obliquely; then refitted without a stroke width at either end, where the cuts
    skew a band into a parallelogram.
    """
    grown = ndimage.binary_dilation(run, iterations=int(np.ceil(width / 2)) + 1)
    px = grown & ink & (outside >= width / 2 + FIT_CLEAR_PX)
    if px.sum() < 3:
        px = run
    ys, xs = np.nonzero(px)
    q = np.stack([xs, ys], axis=1).astype(np.float64)
    axis, centre = _principal(q)
    for _ in range(2):
        s = (q - centre) @ axis
        keep = (s >= s.min() + width) & (s <= s.max() - width)
        if keep.sum() < 3:
            break
        axis, centre = _principal(q[keep])
    s = (q - centre) @ axis
    if len(q) >= 3 * width:  # the band's area over its length: the distance transform understates oblique lines
        width = max(1.0, float(len(q) / (s.max() - s.min() + 1.0)))
    return axis, centre, width


def hermite(p0: np.ndarray, t0: np.ndarray, p1: np.ndarray, t1: np.ndarray, step: float = 0.25) -> np.ndarray:
    """(n, 2) float64 points of the cubic Hermite curve from p0 leaving along unit t0 to p1 arriving along unit t1
    (pixels), tangents scaled by the chord's length, sampled every ~`step` px. Collinear tangents along the
    chord give the straight segment itself."""
    p0, p1 = np.asarray(p0, np.float64), np.asarray(p1, np.float64)
    chord = float(np.linalg.norm(p1 - p0))
    m0, m1 = chord * np.asarray(t0, np.float64), chord * np.asarray(t1, np.float64)
    n = max(2, int(np.ceil(2.0 * chord / step)) + 1)
    s = np.linspace(0.0, 1.0, n)[:, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1


def _pair_cost(a: StrokeEnd, b: StrokeEnd, lab_a: np.ndarray, lab_b: np.ndarray) -> float:
    """Cost of joining ends a and b (inf when they cannot be one line): how far each direction turns from the chord."""
    chord = b.point - a.point
    length = float(np.linalg.norm(chord))
    if length < 1.0:
        return np.inf
    c = chord / length
    ca, cb = float(a.direction @ c), float(-(b.direction @ c))
    if ca < PAIR_MAX_ANGLE_COS or cb < PAIR_MAX_ANGLE_COS:
        return np.inf
    if float(np.linalg.norm(lab_a - lab_b)) > PAIR_MAX_DE:
        return np.inf
    if max(a.width, b.width) > PAIR_MAX_WIDTH_RATIO * min(a.width, b.width):
        return np.inf
    return (1.0 - ca) + (1.0 - cb)


def pair_ends(ends: list[StrokeEnd], hole: np.ndarray) -> tuple[list[StrokePair], list[int]]:
    """Pair stroke ends across a (H, W) bool hole: (pairs, indices of the ends left unpaired).

    Greedy by cost (both directions turned least from the chord first); a pair is kept only when its Hermite
    curve runs inside the hole for PAIR_MIN_INSIDE of its samples. A pair is marked ambiguous when one of
    its ends had another admissible partner within AMBIGUOUS_MARGIN of its cost: the choice then rests on
    that small difference alone.
    """
    n = len(ends)
    labs = [lab(e.colour.reshape(1, 1, 3)).reshape(3) for e in ends]
    cost = np.full((n, n), np.inf)
    curves: dict[tuple[int, int], np.ndarray] = {}
    hole_f = hole.astype(np.float32)
    for i in range(n):
        for j in range(i + 1, n):
            c = _pair_cost(ends[i], ends[j], labs[i], labs[j])
            if not np.isfinite(c):
                continue
            curve = hermite(ends[i].point, ends[i].direction, ends[j].point, -ends[j].direction)
            if (_sample(hole_f, curve) >= 0.5).mean() < PAIR_MIN_INSIDE:
                continue
            cost[i, j] = cost[j, i] = c
            curves[(i, j)] = curve
    pairs, used = [], np.zeros(n, bool)
    order = sorted((cost[i, j], i, j) for i in range(n) for j in range(i + 1, n) if np.isfinite(cost[i, j]))
    for c, i, j in order:
        if used[i] or used[j]:
            continue
        rivals = np.concatenate([np.delete(cost[i], [i, j]), np.delete(cost[j], [i, j])])
        ambiguous = bool((rivals <= c + AMBIGUOUS_MARGIN).any())
        pairs.append(StrokePair(i, j, float(c), curves[(i, j)], ambiguous))
        used[i] = used[j] = True
    return pairs, [int(i) for i in np.nonzero(~used)[0]]


def stroke_alpha(curve: np.ndarray, width: float, shape: tuple[int, int], where: np.ndarray) -> np.ndarray:
    """(H, W) float32 anti-aliased coverage of a stroke of `width` px along `curve` (n, 2) x, y pixels, at the
    pixels of `where` (H, W) bool (0 elsewhere): 1 within half the width of the centre line, falling to 0
    over one pixel."""
    out = np.zeros(shape, np.float32)
    ys, xs = np.nonzero(where)
    if not len(ys):
        return out
    dist, _ = cKDTree(curve).query(np.stack([xs, ys], axis=1).astype(np.float64))
    out[ys, xs] = np.clip(width / 2.0 + 0.5 - dist, 0.0, 1.0)
    return out
