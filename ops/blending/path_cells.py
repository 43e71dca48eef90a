"""The image-matrix cells a blend path takes, known before the matrix is built (§5.2).

The path's costs need only q (the inpainted shares of the two deformed
sequences, known before any blending) and Q (the divergence of the RIFE flow
at alpha = 1/2, known after the first bisection level). So once that level is
done, the optimal and the diagonal path are fixed, and the deeper cells the
output's path does not take need not be blended at all. The quality_metrics
and optimal_path stages later compute the same paths from the stored matrix;
the evaluation blends the other path's cells when it compares the two
(ops.blending.image_matrix.complete_cells).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ops.blending.image_matrix import alpha_grid, build_image_matrix
from ops.blending.path import diagonal_path, optimal_path
from ops.blending.quality import interpolation_quality
from ops.types import DeformedSequence, ImageMatrix

if TYPE_CHECKING:
    from ops.blending.rife import Rife


def path_cells(q: np.ndarray, Q: np.ndarray, alphas: np.ndarray, times: np.ndarray, epsilon: float,
               blend: str = "optimal") -> np.ndarray:
    """q: (T, A) cell cost, Q: (T,) flow cost, alphas: (A,), times: (T,) -> (T, A) bool cells on the path the
    output takes: the optimal one, or the diagonal (alpha = t) for blend "diagonal" (Settings.blend)."""
    if blend not in ("optimal", "diagonal"):
        raise ValueError(f"blend {blend!r}: use 'optimal' or 'diagonal'")
    path = optimal_path(q, Q, alphas, epsilon=epsilon) if blend == "optimal" else diagonal_path(q, Q, alphas, times)
    cells = np.zeros(np.shape(q), dtype=bool)
    cells[np.arange(cells.shape[0]), path.alpha_index] = True
    return cells


def path_matrix(seq0: DeformedSequence, seq1: DeformedSequence, q: np.ndarray, weight: np.ndarray, rife: Rife,
                depth: int, epsilon: float, blend: str = "optimal", batch: int = 1,
                cells: str = "scaled") -> ImageMatrix:
    """The image matrix of two deformed sequences with only the cells of `blend`'s path (and what they need:
    alpha 1/2, or their bisection's parents, by `cells`) blended: q (T, A) and the coverage weight (T, H, W) of Q
    (ops.blending.quality.quality_inputs) known, Q from the alpha-1/2 flows once they are."""
    alphas = alpha_grid(depth)

    def wanted(flows: np.ndarray) -> np.ndarray:
        return path_cells(q, interpolation_quality(flows, weight), alphas, seq0.times, epsilon, blend)

    return build_image_matrix(seq0.images, seq1.images, seq0.times, rife, depth=depth, batch=batch, wanted=wanted,
                              cells=cells)
