"""Ground-truth occlusions: where a nearer part covers a farther one, and the T-junctions of each pair."""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .geometry import part_outline, polygon_crossings, signed_distance, stem_directions
from .model import Character
from .order import draw_order

MIN_OVERLAP_PX = 12  # smaller overlaps are rounding noise, not occlusions
MIN_CROSSING_SIN = 0.2  # adjacent parts: outlines meeting at under ~12 deg are the same joint circle, not a junction


@dataclass
class Occlusion:
    """One overlap of a front part over a back part (issue 15: adjacent parts included)."""

    front: int  # bone index (Skeleton.bones order)
    back: int
    mask: np.ndarray  # (H, W) bool
    junctions: np.ndarray  # (k, 2) float64 px, visible crossings of the two outlines
    adjacent: bool = False  # the two bones share a joint (a joint overlap, a thigh under a skirt on the pelvis)
    joined: bool = False  # painted as one shape (a tail's segments): nothing in the drawing shows this overlap
    stems: np.ndarray | None = None  # (k, 2) unit: the back part's outline leaving each junction, away from the front


def occlusion_pairs(char: Character, pose: np.ndarray, coverage: list[np.ndarray],
                    include_adjacent: bool = True) -> list[Occlusion]:
    """Every pair of drawn parts whose filled shapes overlap by >= MIN_OVERLAP_PX px, front over back.

    coverage: per bone (H, W) float coverage; a pixel belongs to a part's filled shape where it is > 0.5.
    Front and back follow the painting order (joint depth), so the mask is what the drawing hides.
    """
    order = draw_order(char, pose)
    rank = {b: r for r, b in enumerate(order)}
    bones = char.bones
    boxes = {i: _box(coverage[i] > 0.5) for i in rank}
    outlines = {i: part_outline(char.parts[bones[i][1]], pose[bones[i][0], :2], pose[bones[i][1], :2])[0]
                for i in rank}  # computed once: every pair's T-junction test reads them
    out = []
    for i in range(len(bones)):
        for j in range(i + 1, len(bones)):
            if i not in rank or j not in rank:
                continue
            adjacent = char.adjacent(bones[i], bones[j])
            if adjacent and not include_adjacent:
                continue
            if not _boxes_meet(boxes[i], boxes[j]):
                continue
            mask = (coverage[i] > 0.5) & (coverage[j] > 0.5)
            if mask.sum() < MIN_OVERLAP_PX:
                continue
            front, back = (i, j) if rank[i] > rank[j] else (j, i)
            joined = char.joined(i, j)  # painted as one shape: the outlines meet in corners, not T-junctions
            junctions = np.zeros((0, 2)) if joined else t_junctions(char, pose, front, back, rank, adjacent, outlines)
            stems = junction_stems(outlines[back], outlines[front], junctions)
            out.append(Occlusion(front, back, mask, junctions, adjacent, joined, stems))
    return out


def occlusions(char: Character, pose: np.ndarray, coverage: list[np.ndarray]) -> list[Occlusion]:
    """The original definition: every overlapping pair of non-adjacent parts, front over back."""
    return occlusion_pairs(char, pose, coverage, include_adjacent=False)


def _box(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """(y0, y1, x0, x1) bounding box of a mask, or None when empty."""
    ys, xs = np.nonzero(mask.any(1))[0], np.nonzero(mask.any(0))[0]
    return None if not len(ys) else (ys[0], ys[-1], xs[0], xs[-1])


def _boxes_meet(a: tuple | None, b: tuple | None) -> bool:
    """True when two bounding boxes intersect."""
    return a is not None and b is not None and a[0] <= b[1] and b[0] <= a[1] and a[2] <= b[3] and b[2] <= a[3]


def t_junctions(char: Character, pose: np.ndarray, front: int, back: int, rank: dict[int, int],
                adjacent: bool = False, outlines: dict[int, np.ndarray] | None = None) -> np.ndarray:
    """(k, 2) px points where the back part's outline meets the front part's outline, not hidden by a third part.

    outlines: optional cache, bone -> (n, 2) outline polygon (part_outline) in this pose."""
    def outline(b: int) -> np.ndarray:
        if outlines is not None and b in outlines:
            return outlines[b]
        p, c = char.bones[b]
        return part_outline(char.parts[c], pose[p, :2], pose[c, :2])[0]
    pf, pb = outline(front), outline(back)
    pts = polygon_crossings(pb, pf)
    if adjacent and len(pts):  # two arcs of one joint circle cross at grazing angles all along it
        pts = pts[crossing_sines(pb, pf, pts) > MIN_CROSSING_SIN]
    keep = np.ones(len(pts), bool)
    for other in range(len(char.bones)):
        if other in (front, back) or other not in rank or rank[other] < rank[back] or not len(pts):
            continue
        p, c = char.bones[other]
        part = char.parts[c]
        if part.shape == "capsule":
            sd = signed_distance(part, pose[p, :2], pose[c, :2], pts)
        else:
            sd = _polygon_signed_distance(outline(other), pts)
        keep &= sd > -1.0  # inside a later part: the junction is painted over
    pts = pts[keep]
    uniq: list[np.ndarray] = []
    for q in pts:  # merge duplicates from a crossing exactly at a polygon vertex
        if all(np.hypot(*(q - u)) > 2.0 for u in uniq):
            uniq.append(q)
    return np.array(uniq).reshape(-1, 2)


def junction_stems(back: np.ndarray, front: np.ndarray, junctions: np.ndarray) -> np.ndarray:
    """(k, 2) unit directions of the back part's outline polygon (n, 2) away from its junctions (k, 2): the way
    along it that leaves the front part's outline polygon (m, 2), as the drawing shows the covered outline."""
    poly = front.astype(np.float32)
    outside = lambda q: [-cv2.pointPolygonTest(poly, (float(x), float(y)), True) for x, y in q]  # noqa: E731
    return stem_directions(back, junctions, outside)


def _polygon_signed_distance(poly: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(k,) signed distance (px, negative inside) of points q (k, 2) to the vertices of a closed polygon (n, 2);
    the same rule as geometry.signed_distance for non-capsule parts, with a bounding-box shortcut."""
    lo, hi = poly.min(0) - 2, poly.max(0) + 2
    out = np.full(len(q), np.inf)
    near = np.all((q >= lo) & (q <= hi), axis=1)
    if near.any():
        qs = q[near]
        dist = np.min(np.linalg.norm(qs[:, None] - poly[None], axis=2), axis=1)
        inside = np.array([cv2.pointPolygonTest(poly.astype(np.float32), (float(x), float(y)), False) > 0
                           for x, y in qs])
        out[near] = np.where(inside, -dist, dist)
    return out


def crossing_sines(p: np.ndarray, q: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """(k,) |sin| of the angle between polygons p and q at each of their crossing points pts (k, 2)."""
    def tangent(poly: np.ndarray, x: np.ndarray) -> np.ndarray:
        a, b = poly, np.roll(poly, -1, 0)
        ab = b - a
        t = np.clip(((x[:, None] - a[None]) * ab[None]).sum(2) / np.maximum((ab * ab).sum(1), 1e-12)[None], 0, 1)
        dist = np.linalg.norm(a[None] + t[..., None] * ab[None] - x[:, None], axis=2)
        seg = ab[np.argmin(dist, axis=1)]
        return seg / np.maximum(np.linalg.norm(seg, axis=1, keepdims=True), 1e-12)
    tp, tq = tangent(p, pts), tangent(q, pts)
    return np.abs(tp[:, 0] * tq[:, 1] - tp[:, 1] * tq[:, 0])
