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
    a, b = p, np.roll(p, -1, 0)
    c, d = q, np.roll(q, -1, 0)
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
