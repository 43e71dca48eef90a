"""Frames of the image matrix along a blend path (§5.2)."""
from __future__ import annotations

import numpy as np


def select_frames(matrix_frames: np.ndarray, alpha_index: np.ndarray) -> np.ndarray:
    """matrix_frames: (T, A, H, W, 4) (memmap ok), alpha_index: (T,) -> (T, H, W, 4) float32 frames on the path."""
    idx = np.asarray(alpha_index, dtype=np.int64)
    if idx.shape != (matrix_frames.shape[0],):
        raise ValueError(f"alpha_index {idx.shape} must be (T,) = ({matrix_frames.shape[0]},)")
    # fancy indexing reads only the T chosen cells from a memmap
    return np.asarray(matrix_frames[np.arange(len(idx)), idx], dtype=np.float32)
