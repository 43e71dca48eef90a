"""Closed polylines and segments in the image plane: signed area, point inside, nearest point, the pixels inside.

Pure geometry with no mesh in it, so the masks (ops.segmentation.domain) use it without depending on the
mesher (ops.geometry.mesh), and an edit to the mesher leaves them fresh.
"""
from __future__ import annotations

import cv2
import numpy as np


def polygon_area(P: np.ndarray) -> float:
    """Signed area (pixels^2) of the closed polyline P (n, 2) (shoelace)."""
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def points_in_polygon(Q: np.ndarray, P: np.ndarray) -> np.ndarray:
    """(k,) bool even-odd test of points Q (k, 2) against the closed polyline P (n, 2)."""
    a, b = P, np.roll(P, -1, axis=0)
    qx, qy = Q[:, 0:1], Q[:, 1:2]
    straddle = (a[None, :, 1] > qy) != (b[None, :, 1] > qy)
    dy = np.where(b[:, 1] == a[:, 1], 1.0, b[:, 1] - a[:, 1])
    x_cross = a[None, :, 0] + (qy - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / dy[None, :]
    return (straddle & (qx < x_cross)).sum(axis=1) % 2 == 1


def project_to_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest point on the segment a-b ((2,) each) for (..., 2) points: (param (...,) in [0, 1] from a to b,
    distance (...,) pixels); a segment of no length is its point a."""
    d = np.asarray(b, np.float64) - a
    L2 = float(d @ d)
    t = np.zeros(np.shape(points)[:-1]) if L2 < 1e-12 else np.clip(((points - a) @ d) / L2, 0.0, 1.0)
    return t, np.linalg.norm(points - (a + t[..., None] * d), axis=-1)


def project_to_polyline(Q: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest point on the closed polyline P (n, 2) for each Q (k, 2): (param (k,) in [0, n), dist (k,) pixels).

    param = i + s means the point lies at fraction s along edge P[i] -> P[i+1].
    """
    a, b = P, np.roll(P, -1, axis=0)
    e = b - a
    len2 = np.maximum((e**2).sum(1), 1e-300)
    s = ((Q[:, None, :] - a[None]) * e[None]).sum(-1) / len2[None]
    s = np.clip(s, 0.0, 1.0)
    foot = a[None] + s[..., None] * e[None]
    d = np.linalg.norm(Q[:, None, :] - foot, axis=-1)
    i = d.argmin(axis=1)
    rows = np.arange(len(Q))
    return i + s[rows, i], d[rows, i]


def rasterize(P: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(H, W) bool pixels covered by the closed (n, 2) polygon P (pixel centres, boundary included)."""
    img = np.zeros(shape, np.uint8)
    pts = np.round(P * 16).astype(np.int32).reshape(-1, 1, 2)  # 4 fractional bits
    cv2.fillPoly(img, [pts], 1, lineType=cv2.LINE_8, shift=4)
    return img > 0


def box_size(mask: np.ndarray) -> tuple[int, int]:
    """(height, width) pixels of the box around the nonzero pixels of an (H, W) array; (0, 0) when there are none."""
    rows, cols = np.flatnonzero(np.any(mask, axis=1)), np.flatnonzero(np.any(mask, axis=0))
    return (int(rows[-1] - rows[0] + 1), int(cols[-1] - cols[0] + 1)) if len(rows) else (0, 0)


def densify(P: np.ndarray, seg: float, closed: bool = True) -> np.ndarray:
    """(m, 2) polyline with every edge of the (n, 2) polyline P split to length <= seg pixels; closed: P's last
    vertex joins its first (and is not repeated), else P is open and ends at its last vertex."""
    P = np.asarray(P, np.float64).reshape(-1, 2)
    E = (np.roll(P, -1, axis=0) - P) if closed else np.diff(P, axis=0)
    k = np.maximum(1, np.ceil(np.linalg.norm(E, axis=1) / seg).astype(int))
    edge = np.repeat(np.arange(len(E)), k)
    frac = np.concatenate([np.arange(c) / c for c in k]) if len(k) else np.zeros(0)
    out = P[edge] + frac[:, None] * E[edge]
    return out if closed else np.vstack([out, P[-1:]])
