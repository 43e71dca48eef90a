"""Tests of ops.blending.path_cells: the cells of the output's path, decided before blending."""
import numpy as np
import pytest

from ops.blending.path import diagonal_path, optimal_path
from ops.blending.path_cells import path_cells


@pytest.mark.parametrize("seed", range(5))
def test_cells_are_exactly_the_chosen_path(seed):
    """Random q and Q: the marked cells are the chosen path's, one per time, from key 0 to key 1."""
    rng = np.random.default_rng(seed)
    T, A = 7, 9
    q, Q = rng.random((T, A)), rng.random(T) * 5
    alphas, times = np.linspace(0, 1, A), np.linspace(0, 1, T)
    for blend, path in (("optimal", optimal_path(q, Q, alphas, 0.02)), ("diagonal", diagonal_path(q, Q, alphas, times))):
        cells = path_cells(q, Q, alphas, times, 0.02, blend)
        expect = np.zeros((T, A), bool)
        expect[np.arange(T), path.alpha_index] = True
        np.testing.assert_array_equal(cells, expect)
        assert cells[0, 0] and cells[-1, -1] and (cells.sum(1) == 1).all()


def test_an_unknown_blend_is_refused():
    with pytest.raises(ValueError, match="blend"):
        path_cells(np.zeros((3, 5)), np.zeros(3), np.linspace(0, 1, 5), np.linspace(0, 1, 3), 0.02, "straight")
