"""Moving points into a mask: joints and T-junctions clicked just off the drawing."""
from __future__ import annotations

import numpy as np
from scipy import ndimage


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
