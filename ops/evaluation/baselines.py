"""Ground-truth evaluation: the baselines and the per-frame comparison table.

Methods compared (issue 5): ours (optimal path), ours with the diagonal path,
ours with the single-layer template, RIFE applied directly to the two
keyframes (same network, bisection to each t) and a cross-dissolve.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ops.blending.image_matrix import alpha_grid
from ops.blending.key_fallback import interpolate_keys
from ops.blending.path import diagonal_path, optimal_path
from ops.blending.path_cells import path_matrix
from ops.blending.quality import interpolation_quality, quality_inputs
from ops.evaluation.metrics import chamfer, ink_threshold, psnr, ssim
from ops.evaluation.plate import over, paper_plate
from ops.shotio.image_io import to_rgba
from ops.types import BlendPaths, DeformedSequence, ImageMatrix

if TYPE_CHECKING:
    import pandas as pd

METHODS = ("ours", "ours_diagonal", "single_layer", "rife_direct", "cross_dissolve", "held_drawing")


def rife_direct(key0: np.ndarray, key1: np.ndarray, times: np.ndarray, rife) -> np.ndarray:
    """Frame interpolation alone: RIFE bisection between the keyframes (H, W, 4) to each t -> (T, H, W, 4)."""
    return interpolate_keys(key0, key1, times, rife)


def cross_dissolve(key0: np.ndarray, key1: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Linear blend of the keyframes (H, W, 4) at each t -> (T, H, W, 4)."""
    t = np.asarray(times, np.float32)[:, None, None, None]
    return ((1 - t) * key0[None] + t * key1[None]).astype(np.float32)


def blend_sequences(seq0: DeformedSequence, seq1: DeformedSequence, rife, depth: int = 3,
                    epsilon: float = 0.02, cells: str = "scaled") -> tuple[ImageMatrix, BlendPaths]:
    """§5.2 in one call (for the ablation): matrix (the optimal path's cells blended), q and Q, and both paths."""
    _, _, q, weight = quality_inputs(seq0, seq1, alpha_grid(depth))
    matrix = path_matrix(seq0, seq1, q, weight, rife, depth, epsilon, cells=cells)
    Q = interpolation_quality(matrix.flows, weight)
    paths = BlendPaths(matrix.times, matrix.alphas, optimal_path(q, Q, matrix.alphas, epsilon=epsilon),
                       diagonal_path(q, Q, matrix.alphas, matrix.times))
    return matrix, paths


def compare(ground_truth: np.ndarray, methods: dict[str, np.ndarray], times: np.ndarray,
            frames: np.ndarray | None = None, interior: np.ndarray | None = None) -> pd.DataFrame:
    """Per method and scored frame: PSNR, SSIM, Chamfer against ground truth (G, H, W, C); long table.

    frames: (G,) the output frame of each reference (default 0 .. G-1); interior: (G,) bool, frames that are not
    keyframes (default: all but the first and the last)."""
    import pandas as pd  # imported where a table is built: importing this module stays cheap

    G = len(times)
    frames = np.arange(G) if frames is None else np.asarray(frames)
    interior = (np.arange(G) > 0) & (np.arange(G) < G - 1) if interior is None else np.asarray(interior)
    rows = []
    ink = ink_threshold(ground_truth[0])  # one ink level for the shot: its first frame's (the first key)
    for name, got in methods.items():
        for i in range(G):
            rows.append({"method": name, "frame": int(frames[i]), "t": float(times[i]), "interior": bool(interior[i]),
                         "psnr": psnr(got[i], ground_truth[i]), "ssim": ssim(got[i], ground_truth[i]),
                         "chamfer": chamfer(got[i], ground_truth[i], ink)})
    return pd.DataFrame(rows)


def held_drawing(drawing: np.ndarray, count: int) -> np.ndarray:
    """The baseline of a one-drawing shot: the drawing (H, W, 4) held still for count frames -> (count, H, W, 4)."""
    return np.repeat(np.asarray(drawing, np.float32)[None], count, axis=0)


def lane_agreement(frame: np.ndarray, drawing: np.ndarray, coverage: np.ndarray, paper: np.ndarray
                   ) -> tuple[float, float]:
    """(PSNR dB, Chamfer) of a lane's frame (H, W, 4), deformed to another key's pose, against that key's drawing
    (H, W, C), composited over the key's own paper (its bare pixels, its paper model (H, W, 3) under coverage)."""
    plate = paper_plate([drawing], [coverage], [paper])
    got = over(np.asarray(frame)[None], plate)[0]
    want = to_rgba(drawing)[..., :3]
    return psnr(got, want), chamfer(got, want, ink_threshold(want))


def summarize(table: pd.DataFrame) -> pd.DataFrame:
    """Mean over the interior frames per (shot,) method."""
    keys = [c for c in ("shot", "method") if c in table.columns]
    inner = table[table["interior"]].replace([np.inf], np.nan)
    return inner.groupby(keys, sort=False)[["psnr", "ssim", "chamfer"]].mean().reset_index()
