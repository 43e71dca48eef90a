"""Depth weights of a 2.5D template (§5.1): bounded biharmonic weights over the joints.

Every vertex gets weights over the joints, so a face's depth at any pose is
the weighted joint depth.
"""
from __future__ import annotations

import igl
import numpy as np
from scipy.sparse.linalg import spsolve

from ops.geometry.mesh import vertex_components
from ops.types import Template

BBW_MAX_ITER = 8  # active-set iterations: weights settle in a few, each costs a QP solve


def harmonic_weights(V: np.ndarray, F: np.ndarray, b: np.ndarray, bc: np.ndarray) -> np.ndarray:
    """V (n, 2), F (m, 3), b (h,), bc (h, k) -> (n, k) harmonic interpolation of bc (cotangent Laplacian)."""
    L = igl.cotmatrix(V, F).tocsr()
    free = np.setdiff1d(np.arange(V.shape[0]), b)
    W = np.zeros((V.shape[0], bc.shape[1]))
    W[b] = bc
    if free.size:
        rhs = -(L[free][:, b] @ bc)
        sol = spsolve(L[free][:, free].tocsc(), rhs)
        W[free] = sol.reshape(free.size, -1)
    return W


def _solve_weights(V: np.ndarray, F: np.ndarray, b: np.ndarray, bc: np.ndarray) -> np.ndarray:
    """Bounded biharmonic weights (n, k), or harmonic ones where bbw fails (non-manifold seams, QP failure)."""
    if bc.shape[1] == 1:
        return np.ones((V.shape[0], 1))
    try:
        W = igl.bbw(V, F, b, bc, partition_unity=False, max_iter=BBW_MAX_ITER)
        W = np.asarray(W, dtype=np.float64)
        if W.shape == (V.shape[0], bc.shape[1]) and np.isfinite(W).all():
            return W
    except (RuntimeError, ValueError):
        pass
    # bbw's QP can fail on meshes with pockets sewn along part of their boundary; harmonic weights
    # share its boundary conditions and are bounded by the maximum principle, only less smooth.
    return harmonic_weights(V, F, b, bc)


def _normalize_rows(W: np.ndarray) -> np.ndarray:
    """(n, k) -> clipped to [0, 1] with rows summing to 1 (zero rows stay zero)."""
    W = np.clip(W, 0.0, 1.0)
    s = W.sum(axis=1, keepdims=True)
    return np.divide(W, s, out=np.zeros_like(W), where=s > 1e-12)


def depth_weights(template: Template) -> np.ndarray:
    """(n, J) float64 bounded biharmonic weights per joint, rows sum to 1 (handle rows = handle_weights)."""
    V = np.ascontiguousarray(template.rest, dtype=np.float64)
    F = np.ascontiguousarray(template.faces, dtype=np.int64)
    n, J = V.shape[0], template.handle_weights.shape[1]
    handles, first = np.unique(np.asarray(template.handles, dtype=np.int64), return_index=True)
    bc_all = np.asarray(template.handle_weights, dtype=np.float64)[first]
    if handles.size == 0:
        return np.full((n, J), 1.0 / J)
    comp = vertex_components(n, F)
    inside = np.isin(comp, comp[handles])
    sub = np.nonzero(inside)[0]
    local = np.full(n, -1, dtype=np.int64)
    local[sub] = np.arange(sub.size)
    Fs = local[F[inside[F[:, 0]]]]
    cols = np.nonzero(np.abs(bc_all).sum(axis=0) > 0)[0]  # joints no handle uses get weight 0 everywhere
    W = np.zeros((n, J))
    if Fs.shape[0]:
        Ws = _solve_weights(V[sub], Fs, local[handles], bc_all[:, cols])
        W[np.ix_(sub, cols)] = _normalize_rows(Ws)
    W[handles] = bc_all
    # vertices the handles cannot reach (other components, zero rows) follow their nearest handle
    orphan = np.nonzero(~inside | (W.sum(axis=1) < 0.5))[0]
    if orphan.size:
        d = ((V[orphan, None, :] - V[None, handles, :]) ** 2).sum(axis=2)
        W[orphan] = bc_all[d.argmin(axis=1)]
    return W
