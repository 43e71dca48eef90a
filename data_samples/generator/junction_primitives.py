"""Plain geometric drawings with exact T-junctions, for the T-junction network (tools/train_junctions.py).

The character generators build bodies from capsules and ellipses posed by a skeleton; a user's first try (and
tests/ops/segmentation/test_junction_proposals.py) draws plainer things: a bar over a disc, a rectangle with
texture strokes crossing on it. These samples teach that case. A back shape (disc, ellipse, turned rectangle or
lumpy blob) with an ink outline; a front shape (a bar or an ellipse) painted over it across its outline, or
lying wholly inside it (a patch: no junction); texture strokes on the back shape that cross or end inside it
(not T-junctions: nothing is covered). The junctions are where the two outline polygons cross, the back
outline's stems the way along it that leaves the front shape (geometry.stem_directions), as the generators do.

make_primitive(index) -> a dict shaped like tools/occlusion_data.load's samples (image (H, W, 3) uint8, fg
(H, W) uint8 coverage x 255, pose (4, 3): hip and neck on the back shape's axis, shoulder and hand on the front
shape's, z larger = farther; parents; pairs; and for checks the back and front outline polygons (n, 2) and the
texture strokes (2, 2) px), the same for the same index.
"""
from __future__ import annotations

import cv2
import numpy as np

from .geometry import polygon_crossings
from .occlusion import crossing_sines, junction_stems

PARENTS = np.array([-1, 0, 1, 2], np.int64)  # hip -> neck (the back shape), neck -> shoulder, shoulder -> hand
SHIFT = 4  # cv2 sub-pixel bits
MARGIN = 14  # px around the drawing
MAX_SIDE = 256


def _ellipse(c: np.ndarray, a: float, b: float, angle: float, n: int = 96) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    u, v = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
    return c + np.outer(a * np.cos(t), u) + np.outer(b * np.sin(t), v)


def _rectangle(c: np.ndarray, a: float, b: float, angle: float) -> np.ndarray:
    u, v = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
    return np.array([c + sa * a * u + sb * b * v for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def _blob(c: np.ndarray, r: float, rng: np.random.Generator, n: int = 96) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    rad = r * (1 + sum(rng.uniform(-0.08, 0.08) * np.cos(k * t + rng.uniform(0, 2 * np.pi)) for k in (2, 3, 4)))
    return c + rad[:, None] * np.c_[np.cos(t), np.sin(t)]


def _back_shape(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    """(n, 2) outline polygon of the back shape around the origin, (2, 2) its axis (hip, neck), its size px."""
    kind = rng.choice(["disc", "ellipse", "rectangle", "blob"], p=[0.3, 0.3, 0.25, 0.15])
    r = float(rng.uniform(22, 58))
    angle = float(rng.uniform(0, np.pi))
    c = np.zeros(2)
    if kind == "disc":
        a = b = r
        poly = _ellipse(c, r, r, angle)
    elif kind == "ellipse":
        a, b = r, r * float(rng.uniform(0.45, 0.85))
        poly = _ellipse(c, a, b, angle)
    elif kind == "rectangle":
        a, b = r, r * float(rng.uniform(0.4, 1.0))
        poly = _rectangle(c, a, b, angle)
    else:
        a = b = r
        poly = _blob(c, r, rng)
    u = np.array([np.cos(angle), np.sin(angle)])
    return poly, np.array([-0.8 * a * u, 0.8 * a * u]), r


def _front_shape(rng: np.random.Generator, back: np.ndarray, size: float) -> tuple[np.ndarray, np.ndarray]:
    """(m, 2) outline polygon of a front shape over the back one, (2, 2) its axis (shoulder, hand)."""
    kind = rng.choice(["bar", "ellipse", "patch"], p=[0.6, 0.3, 0.1])
    angle = float(rng.uniform(0, 2 * np.pi))
    u = np.array([np.cos(angle), np.sin(angle)])
    if kind == "patch":  # wholly inside the back shape: an outline on a body, no junction
        c = back.mean(0) + rng.uniform(-0.25, 0.25, 2) * size
        a = size * float(rng.uniform(0.15, 0.35))
        b = a * float(rng.uniform(0.4, 1.0))
        return _ellipse(c, a, b, angle, 48), np.array([c - a * u, c + a * u])
    p = back[int(rng.integers(len(back)))]  # a point of the back outline the front shape crosses
    if kind == "bar":
        width = float(rng.uniform(4, 12))
        inner, outer = size * float(rng.uniform(0.3, 2.2)), float(rng.uniform(10, 45))
        a, c = (inner + outer) / 2, p + u * (outer - inner) / 2
        poly = _rectangle(c, a, width, angle) if rng.random() < 0.7 else _ellipse(c, a, width, angle, 64)
        return poly, np.array([p - inner * u, p + outer * u])
    a = float(rng.uniform(10, 0.8 * size))
    b = a * float(rng.uniform(0.35, 1.0))
    c = p + u * float(rng.uniform(-0.5, 0.5)) * a
    return _ellipse(c, a, b, angle, 64), np.array([c - a * u, c + a * u])


def _inside(poly: np.ndarray, pts: np.ndarray, clearance: float) -> np.ndarray:
    """(k,) bool: pts (k, 2) lie inside the polygon (n, 2) by more than clearance px."""
    p = poly.astype(np.float32)
    return np.array([cv2.pointPolygonTest(p, (float(x), float(y)), True) > clearance for x, y in pts])


def _strokes(rng: np.random.Generator, back: np.ndarray, front: np.ndarray, size: float) -> list[np.ndarray]:
    """Texture strokes (2, 2) on the back shape, clear of both outlines: some cross, none ends on an outline."""
    out: list[np.ndarray] = []
    for _ in range(int(rng.choice([0, 1, 2, 2, 3]))):
        for _try in range(20):
            c = back.mean(0) + rng.uniform(-0.6, 0.6, 2) * size
            half = float(rng.uniform(0.2, 0.6)) * size
            if out and rng.random() < 0.6:  # often across the last stroke
                dx, dy = out[-1][1] - out[-1][0]
                angle = np.arctan2(dy, dx) + np.pi / 2 + rng.uniform(-0.5, 0.5)
            else:
                angle = rng.uniform(0, np.pi)
            if out and rng.random() < 0.6:
                c = out[-1].mean(0) + rng.uniform(-0.3, 0.3, 2) * np.linalg.norm(out[-1][1] - out[-1][0]) / 2
            d = half * np.array([np.cos(angle), np.sin(angle)])
            seg = np.array([c - d, c + d])
            along = seg[0] + np.linspace(0, 1, 24)[:, None] * (seg[1] - seg[0])
            if _inside(back, along, 7.0).all() and not _inside(front, along, -8.0).any():
                out.append(seg)
                break
    return out


def _draw_polygon(img: np.ndarray, cover: np.ndarray, poly: np.ndarray, fill, ink, width: int) -> None:
    pts = np.round(poly * (1 << SHIFT)).astype(np.int32)[None]
    cv2.fillPoly(img, pts, fill, cv2.LINE_AA, SHIFT)
    cv2.fillPoly(cover, pts, 255, cv2.LINE_AA, SHIFT)
    if width:
        cv2.polylines(img, pts, True, ink, width, cv2.LINE_AA, SHIFT)
        cv2.polylines(cover, pts, True, 255, width, cv2.LINE_AA, SHIFT)


def _colour(rng: np.random.Generator) -> tuple[int, int, int]:
    if rng.random() < 0.2:  # white-filled line art
        return (255, 255, 255)
    return tuple(int(v) for v in rng.integers(64, 243, 3))


def _distinct(pts: np.ndarray) -> np.ndarray:
    """(k, 2) crossings without the repeats of one found at a polygon vertex (once per edge)."""
    uniq: list[np.ndarray] = []
    for q in pts.reshape(-1, 2):
        if all(np.hypot(*(q - u)) > 1e-6 for u in uniq):
            uniq.append(q)
    return np.array(uniq).reshape(-1, 2)


def make_primitive(index: int) -> dict:
    """One plain drawing with its exact T-junctions (a dict like tools/occlusion_data.load's; see the module)."""
    rng = np.random.default_rng([20271206, index])
    back, hip_neck, size = _back_shape(rng)
    for _ in range(50):
        front, shoulder_hand = _front_shape(rng, back, size)
        junctions = _distinct(polygon_crossings(back, front))
        if _inside(back, front, 3.0).all():
            break  # a patch: no junction
        gaps = np.linalg.norm(junctions[:, None] - junctions[None], axis=2) + 1e9 * np.eye(len(junctions))
        if len(junctions) >= 2 and gaps.min() > 6.0 and crossing_sines(back, front, junctions).min() > 0.3:
            break  # clear crossings (near or grazing ones are ambiguous T's)
    strokes = _strokes(rng, back, front, size)
    joints = np.r_[hip_neck, shoulder_hand]
    drawn = np.r_[back, front, joints]
    lo, hi = drawn.min(0) - MARGIN, drawn.max(0) + MARGIN
    scale = min(1.0, MAX_SIDE / float(np.max(hi - lo)))
    move = lambda q: (np.asarray(q) - lo) * scale  # noqa: E731
    back, front, joints, junctions = move(back), move(front), move(joints), move(junctions)
    strokes = [move(s) for s in strokes]
    h, w = (int(np.ceil(v)) for v in ((hi - lo) * scale)[::-1])
    paper = tuple(int(v) for v in 255 - rng.integers(0, 31, 3) * (rng.random() < 0.5))
    img = np.empty((h, w, 3), np.uint8)  # uint8: OpenCV antialiases only 8-bit drawings
    img[:] = paper
    cover = np.zeros((h, w), np.uint8)
    ink = tuple(int(v) for v in rng.integers(0, 77, 3))
    width = int(rng.choice([1, 2, 2, 3]))
    _draw_polygon(img, cover, back, _colour(rng), ink, width)
    for s in strokes:
        a, b = (tuple(int(v) for v in np.round(p * (1 << SHIFT))) for p in s)
        cv2.line(img, a, b, ink, max(1, width - int(rng.integers(2))), cv2.LINE_AA, SHIFT)
    _draw_polygon(img, cover, front, _colour(rng), ink, width)
    stems = junction_stems(back, front, junctions)
    z = np.array([0.0, 0.0, -1.0, -1.0])  # the front shape's bone is nearer
    return {
        "image": img,
        "fg": cover,
        "pose": np.c_[joints, z],
        "parents": PARENTS.copy(),
        "pairs": [{"front": 2, "back": 0, "adjacent": False, "t_junctions": junctions.tolist(),
                   "t_stems": stems.tolist()}],
        "label": "primitive", "style": "plain", "view": "",
        "back_outline": back, "front_outline": front, "strokes": strokes,
    }
