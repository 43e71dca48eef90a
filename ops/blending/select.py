"""Frames of the image matrix along a blend path (§5.2)."""
from __future__ import annotations

import numpy as np


def select_frames(matrix_frames: np.ndarray, alpha_index: np.ndarray, computed: np.ndarray | None = None) -> np.ndarray:
    """matrix_frames: (T, A, H, W, 4) (memmap ok), alpha_index: (T,), computed: (T, A) bool cells holding their
    blend or None (all) -> (T, H, W, 4) float32 frames on the path; ValueError if the path takes a cell not computed."""
    idx = np.asarray(alpha_index, dtype=np.int64)
    if idx.shape != (matrix_frames.shape[0],):
        raise ValueError(f"alpha_index {idx.shape} must be (T,) = ({matrix_frames.shape[0]},)")
    rows = np.arange(len(idx))
    if computed is not None and not computed[rows, idx].all():
        missing = [(int(t), int(idx[t])) for t in np.nonzero(~computed[rows, idx])[0]]
        raise ValueError(f"the path takes matrix cells (t, alpha index) {missing} that were not computed")
    # fancy indexing reads only the T chosen cells from a memmap
    return np.asarray(matrix_frames[rows, idx], dtype=np.float32)
