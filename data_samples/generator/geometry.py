"""Outline curves of drawn parts, their signed distance, and crossings of two outlines (px, y down)."""
from __future__ import annotations

import math

import cv2
import numpy as np

from .model import Part

ARC_SAMPLES = 48  # outline vertices per half shape


def part_outline(part: Part, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closed centre line of a part's outline: (n, 2) points px, (n, 2) outward unit normals, (n,) param in [0, 2pi)."""
    d = p1 - p0
    phi = math.atan2(d[1], d[0])
    n = ARC_SAMPLES
    if part.shape == "capsule":
        a1 = phi + np.linspace(-math.pi / 2, math.pi / 2, n)
        a0 = phi + np.linspace(math.pi / 2, 3 * math.pi / 2, n)
        normals = np.concatenate([np.stack([np.cos(a1), np.sin(a1)], 1), np.stack([np.cos(a0), np.sin(a0)], 1)])
        centres = np.concatenate([np.repeat(p1[None], n, 0), np.repeat(p0[None], n, 0)])
        pts = centres + part.radius * normals
    elif part.shape == "ellipse":
        s = np.linspace(0, 2 * math.pi, 2 * n, endpoint=False)
        a, b = 0.5 * float(np.hypot(*d)) + part.pad, part.radius
        rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
        pts = 0.5 * (p0 + p1) + np.stack([a * np.cos(s), b * np.sin(s)], 1) @ rot.T
        nrm = np.stack([b * np.cos(s), a * np.sin(s)], 1) @ rot.T
        normals = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    elif part.shape == "head":  # an ellipse centred on the child joint: half-axes pad (along) and radius
        s = np.linspace(0, 2 * math.pi, 2 * n, endpoint=False)
        a, b = part.pad, part.radius
        rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
        pts = p1 + np.stack([a * np.cos(s), b * np.sin(s)], 1) @ rot.T
        nrm = np.stack([b * np.cos(s), a * np.sin(s)], 1) @ rot.T
        normals = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    elif part.shape == "taper":
        pts, normals = _taper(part, p0, p1, phi)
    elif part.shape == "trapezoid":
        pts, normals = _trapezoid(part, p0, p1, phi)
    else:
        raise ValueError(f"part shape {part.shape!r} has no outline")
    if part.offset:  # shifted across the bone toward the texture's +v side
        pts = pts + part.offset * np.array([-math.sin(phi), math.cos(phi)])
    param = np.linspace(0, 2 * math.pi, len(pts), endpoint=False)
    return pts, normals, param


def _taper(part: Part, p0: np.ndarray, p1: np.ndarray, phi: float) -> tuple[np.ndarray, np.ndarray]:
    """Convex hull of two circles (radius at p0, radius1 at p1): (2n, 2) points and outward normals."""
    r0, r1 = part.radius, part.radius if part.radius1 is None else part.radius1
    length = max(float(np.hypot(*(p1 - p0))), 1e-9)
    theta = math.acos(float(np.clip((r0 - r1) / length, -1.0, 1.0)))  # tangent normals make this angle with the bone
    n = ARC_SAMPLES
    a1 = phi + np.linspace(-theta, theta, n)
    a0 = phi + np.linspace(theta, 2 * math.pi - theta, n)
    normals = np.concatenate([np.stack([np.cos(a1), np.sin(a1)], 1), np.stack([np.cos(a0), np.sin(a0)], 1)])
    pts = np.concatenate([p1 + r1 * normals[:n], p0 + r0 * normals[n:]])
    return pts, normals


def _trapezoid(part: Part, p0: np.ndarray, p1: np.ndarray, phi: float) -> tuple[np.ndarray, np.ndarray]:
    """Skirt or lamp shade: straight sides from half-width radius (p0) to radius1 (p1), hem bulging by pad."""
    r0, r1 = part.radius, part.radius if part.radius1 is None else part.radius1
    length = float(np.hypot(*(p1 - p0)))
    k = ARC_SAMPLES // 2
    w = np.linspace(r1, -r1, k, endpoint=False)
    hem = np.stack([length + part.pad * (1 - (w / r1) ** 2), w], 1)
    side_a = np.stack([np.linspace(length, 0, k, endpoint=False), np.linspace(-r1, -r0, k, endpoint=False)], 1)
    waist = np.stack([np.zeros(k), np.linspace(-r0, r0, k, endpoint=False)], 1)
    side_b = np.stack([np.linspace(0, length, k, endpoint=False), np.linspace(r0, r1, k, endpoint=False)], 1)
    local = np.concatenate([hem, side_a, waist, side_b])
    rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    pts = p0 + local @ rot.T
    return pts, polygon_normals(pts)


def polygon_normals(pts: np.ndarray) -> np.ndarray:
    """(n, 2) outward unit normals of a closed polygon (n, 2), from central differences."""
    t = np.roll(pts, -1, 0) - np.roll(pts, 1, 0)
    nrm = np.stack([t[:, 1], -t[:, 0]], 1)
    area = 0.5 * float(np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1]))
    if area < 0:
        nrm = -nrm
    return nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)


def signed_distance(part: Part, p0: np.ndarray, p1: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(k,) approximate signed distance (px, negative inside) of points q (k, 2) to a part's outline."""
    if part.shape == "none":
        return np.full(len(q), np.inf)
    if part.shape == "capsule":
        d = p1 - p0
        t = np.clip(((q - p0) @ d) / max(float(d @ d), 1e-12), 0, 1)
        return np.linalg.norm(q - (p0 + t[:, None] * d), axis=1) - part.radius
    pts, _, _ = part_outline(part, p0, p1)
    dist = np.min(np.linalg.norm(q[:, None] - pts[None], axis=2), axis=1)
    inside = np.array([cv2.pointPolygonTest(pts.astype(np.float32), (float(x), float(y)), False) > 0 for x, y in q])
    return np.where(inside, -dist, dist)


def polygon_crossings(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(k, 2) intersection points of two closed polygons p (n, 2) and q (m, 2), px."""
    return segment_crossings(p, np.roll(p, -1, 0), q, np.roll(q, -1, 0))


def segment_crossings(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(k, 2) intersection points of segments a-b (n, 2 each) with segments c-d (m, 2 each), px."""
    r = (b - a)[:, None]  # (n, 1, 2)
    s = (d - c)[None]  # (1, m, 2)
    den = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    ca = c[None] - a[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ca[..., 0] * s[..., 1] - ca[..., 1] * s[..., 0]) / den
        u = (ca[..., 0] * r[..., 1] - ca[..., 1] * r[..., 0]) / den
    hit = (np.abs(den) > 1e-12) & (t >= 0) & (t < 1) & (u >= 0) & (u < 1)
    i, _ = np.nonzero(hit)
    return a[i] + t[hit][:, None] * (b - a)[i]


def walk_along(poly: np.ndarray, pts: np.ndarray, dist: float, closed: bool = True) -> np.ndarray:
    """(k, 2, 2) the points `dist` px along a polyline (n, 2) from the nearest location of each of pts (k, 2),
    backward ([:, 0]) and forward ([:, 1]) along its vertex order; an open polyline stops at its ends."""
    poly = np.asarray(poly, np.float64)
    a = poly
    b = np.roll(poly, -1, 0) if closed else np.concatenate([poly[1:], poly[-1:]])
    ab = b - a
    seg = np.linalg.norm(ab, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])  # arc length at each vertex (cum[-1]: the whole length)
    total = cum[-1]
    out = np.zeros((len(pts), 2, 2))
    for k, q in enumerate(np.asarray(pts, np.float64).reshape(-1, 2)):
        t = np.clip(((q - a) * ab).sum(1) / np.maximum(seg**2, 1e-12), 0.0, 1.0)
        d = np.linalg.norm(a + t[:, None] * ab - q, axis=1)
        i = int(np.argmin(d))
        s0 = cum[i] + t[i] * seg[i]
        for j, s in enumerate((s0 - dist, s0 + dist)):
            s = s % total if closed and total > 0 else float(np.clip(s, 0.0, total))
            v = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(poly) - 1))
            u = (s - cum[v]) / max(seg[v], 1e-12) if v < len(seg) else 0.0
            out[k, j] = a[v] + min(u, 1.0) * ab[v]
    return out


def stem_directions(back: np.ndarray, pts: np.ndarray, outside, dist: float = 6.0, closed: bool = True
                    ) -> np.ndarray:
    """(k, 2) unit directions of a covered part's outline (n, 2) away from its T-junctions pts (k, 2): of the
    two ways along the outline, the one that leaves the covering part. outside: (m, 2) points -> (m,) how far
    outside the covering part each lies (larger = farther out)."""
    if not len(pts):
        return np.zeros((0, 2))
    ends = walk_along(back, pts, dist, closed)  # (k, 2, 2)
    score = np.asarray(outside(ends.reshape(-1, 2)), np.float64).reshape(-1, 2)
    pick = ends[np.arange(len(pts)), np.argmax(score, axis=1)]
    d = pick - np.asarray(pts, np.float64).reshape(-1, 2)
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
