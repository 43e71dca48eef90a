"""Shortest-path blending through the image matrix I(t, alpha) (§5.2).

Vertices are the cells (t_i, alpha_j) with cost q(t_i, alpha_j); an edge
joins (t, alpha_i) to (t + 1, alpha_j) whenever alpha_j - alpha_i > -epsilon
(alpha may not go back, up to grid tolerance). The path runs from I(0, 0)
(keyframe 0's own deformed frame) to I(1, 1) (keyframe 1's).

Decision on the edge cost: the paper's rule 0.5 (Q(t) + Q(t + 1)) depends
only on t, so every path would pay exactly the same sum and the term could
not influence the choice. We weight it by how far the path moves in alpha:

    edge cost = w 0.5 (Q(t) + Q(t + 1)) (T - 1) (alpha_j - alpha_i)^2 + q(t + 1, alpha_j)

Summed along a path, the Q part is the discrete Dirichlet energy of the
blending schedule alpha(t) on normalized time, weighted by how much the two
deformed sequences disagree (Q: divergence of the RIFE flow between them).
A jump from alpha 0 to 1 in one frame (a visible pop) costs T - 1 times a
steady cross-fade; the path moves alpha where the sequences agree and stays
on the sequence with less inpainted texture (q) where they do not. (A cell
cost Q(t) * f(alpha) alone would be free at alpha 0 and 1 and make that pop
the optimum.)

The weight w (TRANSITION_WEIGHT) sets how the two terms trade, since Q and q
have no common unit. It was 1 until every cell of every sample's matrix was
scored against its ground truth: with q linear in alpha, a light Dirichlet
term lets the path sit on one lane and cross over in two or three frames,
and where the lanes disagree (a redrawn shape, a limb the lane tears) a
slower cross-fade is nearer the truth. Mean PSNR of the optimal path over
the 12 two-key samples, per w: 0.25: 32.671, 1: 32.806, 2: 32.837,
4: 32.853, 8: 32.825, 16: 32.818, 64: 32.607, diagonal 31.563. w = 4 is the
samples' best; on shots it was not chosen on it moved the held-out redrawn
shots 26.908 -> 27.303 dB and the realdev drawings 30.042 -> 30.113
(docs/benchmarks.md). A smoother path leaves alpha 0 and 1 more often, so it
blends more cells: 12.9 -> 13.8 RIFE calls per sample on average.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from ops.types import BlendPath

ABRUPT_FLOOR = 1e-6  # step costs below this are never abrupt (an all-zero shot flags nothing)
TRANSITION_WEIGHT = 4.0  # w: the Dirichlet term's weight against q (module docstring)


def transition_cost(Q: np.ndarray, alpha_from: np.ndarray, alpha_to: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Q: (T,), alphas (...,) of the step t -> t + 1 (t (...,) int) -> (...,) w 0.5 (Q(t) + Q(t+1)) (T-1) dalpha^2,
    w = TRANSITION_WEIGHT."""
    n_steps = len(Q) - 1
    return TRANSITION_WEIGHT * 0.5 * (Q[t] + Q[t + 1]) * n_steps * (np.asarray(alpha_to) - np.asarray(alpha_from)) ** 2


def _check(q: np.ndarray, Q: np.ndarray, alphas: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate shapes and signs; returns float64 copies of q (T, A), Q (T,), alphas (A,)."""
    q = np.asarray(q, dtype=np.float64)
    Q = np.asarray(Q, dtype=np.float64)
    alphas = np.asarray(alphas, dtype=np.float64)
    if q.ndim != 2 or q.shape != (Q.shape[0], alphas.shape[0]) or Q.ndim != 1:
        raise ValueError(f"q {q.shape} must be (T, A), Q {Q.shape} (T,), alphas {alphas.shape} (A,)")
    if q.shape[0] < 2:
        raise ValueError("a blend path needs at least two times (the two keyframes)")
    if not (np.isfinite(q).all() and np.isfinite(Q).all()) or (q < 0).any() or (Q < 0).any():
        raise ValueError("q and Q must be finite and non-negative (Dijkstra needs non-negative weights)")
    return q, Q, alphas


def _end_indices(alphas: np.ndarray) -> tuple[int, int]:
    """Grid indices of the cells nearest alpha = 0 and alpha = 1."""
    return int(np.argmin(np.abs(alphas))), int(np.argmin(np.abs(alphas - 1.0)))


def path_cost(q: np.ndarray, Q: np.ndarray, alphas: np.ndarray,
              alpha_index: np.ndarray) -> tuple[float, np.ndarray]:
    """q: (T, A), Q: (T,), alphas: (A,), alpha_index: (T,) int -> (total cost, (T - 1,) step costs)."""
    q, Q, alphas = _check(q, Q, alphas)
    idx = np.asarray(alpha_index, dtype=np.int64)
    t = np.arange(q.shape[0] - 1)
    steps = transition_cost(Q, alphas[idx[:-1]], alphas[idx[1:]], t) + q[t + 1, idx[1:]]
    return float(q[0, idx[0]] + steps.sum()), steps


def abrupt_steps(step_costs: np.ndarray, abrupt_factor: float = 4.0, floor: float = ABRUPT_FLOOR) -> np.ndarray:
    """step_costs: (T - 1,) -> (T - 1,) bool: step > abrupt_factor * median and > floor."""
    s = np.asarray(step_costs, dtype=np.float64)
    if s.size == 0:
        return np.zeros(0, dtype=bool)
    return (s > abrupt_factor * np.median(s)) & (s > floor)


def _graph(q: np.ndarray, Q: np.ndarray, alphas: np.ndarray, epsilon: float) -> sp.csr_matrix:
    """Sparse (T A, T A) edge-cost matrix; node index = t * A + alpha index."""
    n_t, n_a = q.shape
    ok = (alphas[None, :] - alphas[:, None]) > -epsilon  # (A_from, A_to) allowed moves
    src_a, dst_a = np.nonzero(ok)
    t = np.arange(n_t - 1)[:, None]
    cost = transition_cost(Q, alphas[src_a][None], alphas[dst_a][None], t) + q[t + 1, dst_a[None]]
    rows = (t * n_a + src_a[None]).ravel()
    cols = ((t + 1) * n_a + dst_a[None]).ravel()
    # Explicitly stored zeros are edges for csgraph, so zero-cost moves survive.
    return sp.csr_matrix((cost.ravel(), (rows, cols)), shape=(n_t * n_a, n_t * n_a))


def _blend_path(q: np.ndarray, Q: np.ndarray, alphas: np.ndarray, idx: np.ndarray,
                abrupt_factor: float) -> BlendPath:
    """Package a per-time alpha index (T,) with its shared cost accounting."""
    cost, steps = path_cost(q, Q, alphas, idx)
    return BlendPath(alpha_index=np.asarray(idx, dtype=np.int64), cost=cost, step_costs=steps,
                     abrupt=abrupt_steps(steps, abrupt_factor))


def optimal_path(q: np.ndarray, Q: np.ndarray, alphas: np.ndarray, epsilon: float = 0.02,
                 abrupt_factor: float = 4.0) -> BlendPath:
    """q: (T, A) cell cost, Q: (T,) flow cost, alphas: (A,) -> Dijkstra path from I(0, 0) to I(1, 1)."""
    q, Q, alphas = _check(q, Q, alphas)
    n_t, n_a = q.shape
    a0, a1 = _end_indices(alphas)
    start, goal = a0, (n_t - 1) * n_a + a1
    dist, pred = dijkstra(_graph(q, Q, alphas, epsilon), directed=True, indices=start,
                          return_predecessors=True)
    if not np.isfinite(dist[goal]):
        raise ValueError("no path from alpha 0 to alpha 1: the alpha grid and epsilon allow no monotone route")
    nodes = [goal]
    while nodes[-1] != start:
        nodes.append(int(pred[nodes[-1]]))
    idx = np.array(nodes[::-1], dtype=np.int64) % n_a
    return _blend_path(q, Q, alphas, idx, abrupt_factor)


def diagonal_path(q: np.ndarray, Q: np.ndarray, alphas: np.ndarray, times: np.ndarray,
                  abrupt_factor: float = 4.0) -> BlendPath:
    """q: (T, A), Q: (T,), alphas: (A,), times: (T,) in [0, 1] -> the naive path alpha = t (nearest grid alpha)."""
    q, Q, alphas = _check(q, Q, alphas)
    times = np.asarray(times, dtype=np.float64)
    if times.shape != (q.shape[0],):
        raise ValueError(f"times {times.shape} must be (T,) = ({q.shape[0]},)")
    idx = np.argmin(np.abs(times[:, None] - alphas[None, :]), axis=1)
    return _blend_path(q, Q, alphas, idx, abrupt_factor)
