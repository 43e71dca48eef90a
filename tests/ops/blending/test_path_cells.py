"""Tests of ops.blending.path_cells: the cells of the optimal and the diagonal path, decided before blending."""
import numpy as np
import pytest

from ops.blending.path import diagonal_path, optimal_path
from ops.blending.path_cells import path_cells


@pytest.mark.parametrize("seed", range(5))
def test_cells_are_exactly_both_paths(seed):
    """Random q and Q: the marked cells are the union of the two paths' cells, one or two per time."""
    rng = np.random.default_rng(seed)
    T, A = 7, 9
    q, Q = rng.random((T, A)), rng.random(T) * 5
    alphas, times = np.linspace(0, 1, A), np.linspace(0, 1, T)
    cells = path_cells(q, Q, alphas, times, 0.02)
    expect = np.zeros((T, A), bool)
    for p in (optimal_path(q, Q, alphas, 0.02), diagonal_path(q, Q, alphas, times)):
        expect[np.arange(T), p.alpha_index] = True
    np.testing.assert_array_equal(cells, expect)
    assert cells[0, 0] and cells[-1, -1] and (1 <= cells.sum(1)).all() and (cells.sum(1) <= 2).all()
