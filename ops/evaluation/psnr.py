"""PSNR, the one metric the pipeline itself reads (a lane against the other key's drawing, ops.evaluation.lane_checks):
a module of its own, so that a change to the evaluation's other metrics (ops.evaluation.metrics) leaves the lanes'
code version, and their stored outputs, as they are."""
from __future__ import annotations

import numpy as np


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """a, b: same-shape arrays in [0, 1] -> PSNR in dB over all values (inf if identical).

    RGBA inputs (H, W, 4) are composited over white first, like SSIM and Chamfer: a transparent
    pixel is blank paper, whatever its stored colour.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.ndim == 3 and a.shape[-1] == 4:
        a = a[..., :3] * a[..., 3:] + (1.0 - a[..., 3:])
    if b.ndim == 3 and b.shape[-1] == 4:
        b = b[..., :3] * b[..., 3:] + (1.0 - b[..., 3:])
    if a.shape != b.shape:
        raise ValueError(f"psnr needs equal shapes, got {a.shape} and {b.shape}")
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0.0 else float(10.0 * np.log10(1.0 / mse))
