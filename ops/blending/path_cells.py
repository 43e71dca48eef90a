"""The image-matrix cells a blend path takes, known before the matrix is built (§5.2).

The path's costs need only q (the inpainted shares of the two deformed
sequences, known before any blending) and Q (the divergence of the RIFE flow
at alpha = 1/2, known after the first bisection level). So once that level is
done, the optimal and the diagonal path are fixed, and the deeper cells no
path takes need not be blended at all. The quality_metrics and optimal_path
stages later compute the same paths from the stored matrix.
"""
from __future__ import annotations

import numpy as np

from ops.blending.path import diagonal_path, optimal_path


def path_cells(q: np.ndarray, Q: np.ndarray, alphas: np.ndarray, times: np.ndarray, epsilon: float) -> np.ndarray:
    """q: (T, A) cell cost, Q: (T,) flow cost, alphas: (A,), times: (T,) -> (T, A) bool cells on the optimal
    or the diagonal path."""
    cells = np.zeros(np.shape(q), dtype=bool)
    rows = np.arange(cells.shape[0])
    for path in (optimal_path(q, Q, alphas, epsilon=epsilon), diagonal_path(q, Q, alphas, times)):
        cells[rows, path.alpha_index] = True
    return cells
