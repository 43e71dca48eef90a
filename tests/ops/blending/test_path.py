"""Shortest path through the image matrix: Dijkstra against brute force, endpoints, flags."""
import itertools

import numpy as np
import pytest

from ops.blending.path import TRANSITION_WEIGHT, diagonal_path, optimal_path, path_cost, transition_cost


def _brute_force(q, Q, alphas, epsilon):
    """Minimum cost over every admissible path, by enumeration."""
    T, A = q.shape
    a0, a1 = int(np.argmin(np.abs(alphas))), int(np.argmin(np.abs(alphas - 1)))
    best = np.inf
    for mid in itertools.product(range(A), repeat=T - 2):
        idx = (a0, *mid, a1)
        if all(alphas[j] - alphas[i] > -epsilon for i, j in zip(idx[:-1], idx[1:])):
            best = min(best, path_cost(q, Q, alphas, np.array(idx))[0])
    return best


GRIDS = [
    np.linspace(0, 1, 5),                       # dyadic quarters
    np.array([0.0, 0.5, 1.0]),
    np.array([0.0, 0.3, 0.31, 0.7, 1.0]),      # 0.31 -> 0.3 allowed by epsilon
    np.array([0.0, 0.49, 0.5, 0.51, 1.0]),     # several near-equal alphas
]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("grid", range(len(GRIDS)))
@pytest.mark.parametrize("T", [2, 3, 5])
def test_dijkstra_equals_brute_force(seed, grid, T):
    rng = np.random.default_rng(seed * 31 + grid * 7 + T)
    alphas = GRIDS[grid]
    q = rng.random((T, len(alphas))) ** 3          # skewed so some cells are much cheaper
    Q = rng.random(T) * rng.choice([0.1, 1.0, 10.0])
    eps = 0.02
    path = optimal_path(q, Q, alphas, epsilon=eps)
    assert path.cost == pytest.approx(_brute_force(q, Q, alphas, eps), rel=1e-12, abs=1e-12)
    # endpoints, one cell per time, admissible moves, consistent accounting
    assert path.alpha_index.shape == (T,)
    assert alphas[path.alpha_index[0]] == 0.0 and alphas[path.alpha_index[-1]] == 1.0
    assert (np.diff(alphas[path.alpha_index]) > -eps).all()
    cost, steps = path_cost(q, Q, alphas, path.alpha_index)
    assert cost == pytest.approx(path.cost) and np.allclose(steps, path.step_costs)
    assert path.step_costs.shape == (T - 1,) and path.abrupt.shape == (T - 1,)


def test_epsilon_backstep_is_used_when_cheaper():
    alphas = np.array([0.0, 0.3, 0.31, 1.0])
    q = np.full((4, 4), 10.0)
    q[1, 2] = 0.0; q[2, 1] = 0.0; q[:, 0] = 10.0; q[0, 0] = 0.0; q[3, 3] = 0.0
    path = optimal_path(q, np.zeros(4), alphas, epsilon=0.02)
    np.testing.assert_array_equal(path.alpha_index, [0, 2, 1, 3])
    strict = optimal_path(q, np.zeros(4), alphas, epsilon=0.0)   # no going back at all
    assert (np.diff(strict.alpha_index) >= 0).all() and strict.cost > path.cost


def test_transition_cost_spreads_the_blend_where_sequences_agree():
    # q = 0: only the Q-weighted Dirichlet energy of alpha(t) matters
    alphas = np.linspace(0, 1, 9)
    T = 5
    even = optimal_path(np.zeros((T, 9)), np.ones(T), alphas)
    np.testing.assert_array_equal(alphas[even.alpha_index], [0, 0.25, 0.5, 0.75, 1])  # the diagonal, no pop
    jump = path_cost(np.zeros((T, 9)), np.ones(T), alphas, np.array([0, 0, 0, 0, 8]))[0]
    w = TRANSITION_WEIGHT
    assert jump == pytest.approx(w * (T - 1)) and even.cost == pytest.approx(w * 1.0)
    # where the sequences disagree strongly (large Q), alpha moves less
    Q = np.array([1.0, 1.0, 50.0, 50.0, 1.0])
    skew = optimal_path(np.zeros((T, 9)), Q, alphas)
    steps = np.diff(alphas[skew.alpha_index])
    # steps 1-3 touch the disagreeing frames 2 and 3; step 0 (weight 1) is the cheap place to cross-fade
    assert steps[0] == steps.max() and steps[1:3].sum() < steps[0]
    assert transition_cost(Q, np.array(0.0), np.array(0.5), np.array(0)) == pytest.approx(w * 0.5 * 2 * 4 * 0.25)


def test_diagonal_path_on_dyadic_grid():
    alphas = np.arange(9) / 8.0
    times = np.linspace(0, 1, 9)
    rng = np.random.default_rng(1)
    q, Q = rng.random((9, 9)), rng.random(9)
    d = diagonal_path(q, Q, alphas, times)
    np.testing.assert_array_equal(d.alpha_index, np.arange(9))
    assert d.cost == pytest.approx(path_cost(q, Q, alphas, np.arange(9))[0])
    # times between grid points snap to the nearest alpha
    d2 = diagonal_path(q[:5], Q[:5], alphas, np.array([0.0, 0.26, 0.5, 0.74, 1.0]))
    np.testing.assert_array_equal(d2.alpha_index, [0, 2, 4, 6, 8])
    assert optimal_path(q, Q, alphas).cost <= d.cost + 1e-12


def test_abrupt_flag_on_constructed_spike():
    alphas = np.array([0.0, 0.5, 1.0])
    T = 8
    q = np.full((T, 3), 0.01)
    q[0, 0] = 0.0
    q[5, :] = 1.0                          # every path pays the spike at t = 5
    path = optimal_path(q, np.zeros(T), alphas)
    expected = np.zeros(T - 1, bool); expected[4] = True
    np.testing.assert_array_equal(path.abrupt, expected)
    assert path.step_costs[4] == pytest.approx(1.0)


def test_bad_inputs_raise():
    with pytest.raises(ValueError):
        optimal_path(-np.ones((3, 3)), np.zeros(3), np.linspace(0, 1, 3))
    with pytest.raises(ValueError):
        optimal_path(np.zeros((1, 3)), np.zeros(1), np.linspace(0, 1, 3))
    with pytest.raises(ValueError):
        optimal_path(np.zeros((3, 2)), np.zeros(3), np.linspace(0, 1, 3))
