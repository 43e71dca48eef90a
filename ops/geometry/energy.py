"""Symmetric Dirichlet deformation energy plus the skeletal pose term (§4.3).

All quantities live in *normalized* coordinates: the rest mesh is translated
to its centroid and scaled so the total rest area is 1; face weights a_f are
the normalized rest areas (sum 1), so the identity map has E_SD = 4 exactly.

    E(x) = sum_f a_f (||J_f||_F^2 + ||J_f^-1||_F^2) + mu * sum_h ||x_h - target_h||^2

For 2x2 maps ||J^-1||_F^2 = ||J||_F^2 / det(J)^2, which gives a closed-form,
vectorized gradient. Inverted or degenerate triangles give E = +inf.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ops.geometry.mesh import signed_areas


@dataclass
class Normalization:
    """x_normalized = (x_pixels - center) * scale."""

    center: np.ndarray  # (2,) float64 pixels
    scale: float  # 1 / pixels

    def to_norm(self, X: np.ndarray) -> np.ndarray:
        """(k, 2) pixels -> (k, 2) normalized."""
        return (np.asarray(X, dtype=np.float64) - self.center) * self.scale

    def to_pixels(self, X: np.ndarray) -> np.ndarray:
        """(k, 2) normalized -> (k, 2) pixels."""
        return X / self.scale + self.center


def normalization(rest: np.ndarray, faces: np.ndarray) -> Normalization:
    """Centroid-and-scale map making the total rest area of faces (m, 3) over rest (n, 2) pixels equal 1."""
    a = np.abs(signed_areas(rest, faces))
    total = float(a.sum())
    if not total > 0:
        raise ValueError("rest mesh has zero total area")
    cent = (rest[faces].mean(axis=1) * a[:, None]).sum(0) / total
    return Normalization(center=cent, scale=1.0 / np.sqrt(total))


class SymmetricDirichlet:
    """E_SD + pose term on a fixed rest mesh; evaluate with `value_grad` on normalized positions (n, 2)."""

    def __init__(self, rest_n: np.ndarray, faces: np.ndarray, handles: np.ndarray, mu: float = 200.0):
        """rest_n: (n, 2) normalized rest positions; faces (m, 3) int64; handles (h,) int64 vertex ids."""
        self.n, self.faces = len(rest_n), np.asarray(faces, dtype=np.int64)
        self.handles, self.mu = np.asarray(handles, dtype=np.int64), float(mu)
        area = signed_areas(rest_n, self.faces)
        if (area <= 0).any():
            raise ValueError(f"rest mesh has {int((area <= 0).sum())} non-positive-area face(s)")
        self.weight = area / area.sum()
        self.K = _jacobian_operator(rest_n, self.faces)
        self.KT = self.K.T.tocsr()  # transposing per call costs more than the product itself

    def jacobians_T(self, X: np.ndarray) -> np.ndarray:
        """(m, 2, 2) transposed per-face Jacobians J_f^T of positions X (n, 2), normalized."""
        return (self.K @ X).reshape(-1, 2, 2)

    def value_grad(self, X: np.ndarray, targets: np.ndarray, need_grad: bool = True):
        """(E, dE/dX (n, 2) or None) at X (n, 2) with handle targets (h, 2), all normalized; E = inf if folded."""
        M = (self.K @ X).reshape(-1, 4)  # rows (p, q, r, s) of J^T = [[p, q], [r, s]]
        p, q, r_, s = M[:, 0], M[:, 1], M[:, 2], M[:, 3]
        det = p * s - q * r_
        if not (det > 0).all():
            return np.inf, None
        fro = (M * M).sum(axis=1)
        inv_d2 = 1.0 / (det * det)
        res = X[self.handles] - targets
        E = float(np.dot(self.weight, fro * (1.0 + inv_d2)) + self.mu * (res * res).sum())
        if not need_grad:
            return E, None
        # d/dM [w |M|^2 (1 + 1/det^2)] = 2 w (1 + 1/det^2) M - 2 w |M|^2 / det^3 cof(M)
        c1 = 2.0 * self.weight * (1.0 + inv_d2)
        c2 = 2.0 * self.weight * fro * inv_d2 / det
        gM = c1[:, None] * M
        gM[:, 0] -= c2 * s
        gM[:, 1] += c2 * r_
        gM[:, 2] += c2 * q
        gM[:, 3] -= c2 * p
        G = self.KT @ gM.reshape(-1, 2)
        np.add.at(G, self.handles, 2.0 * self.mu * res)
        return E, G

    def energy(self, X: np.ndarray, targets: np.ndarray) -> float:
        """Total energy at X (n, 2) with targets (h, 2), normalized."""
        return self.value_grad(X, targets, need_grad=False)[0]


def _jacobian_operator(rest_n: np.ndarray, faces: np.ndarray) -> sp.csr_matrix:
    """(2m, n) sparse K with (K @ X).reshape(m, 2, 2)[f] = J_f^T, J_f = D_f(X) R_f^-1, D = [x1-x0, x2-x0]."""
    m = len(faces)
    R = np.stack([rest_n[faces[:, 1]] - rest_n[faces[:, 0]], rest_n[faces[:, 2]] - rest_n[faces[:, 0]]], axis=2)
    Rinv = np.linalg.inv(R)  # (m, 2, 2); J^T = R^-T D^T, rows of D^T are the edge vectors
    A = np.transpose(Rinv, (0, 2, 1))  # R^-T
    # Row 2f+i of K: sum_j A[f, i, j] * (x_{j+1} - x_0)
    rows = np.repeat(np.arange(2 * m), 3)
    cols = np.stack([faces[:, [0, 1, 2]]] * 2, axis=1).reshape(-1)
    vals = np.stack([-A.sum(axis=2), A[:, :, 0], A[:, :, 1]], axis=2).reshape(-1)
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * m, len(rest_n)))
