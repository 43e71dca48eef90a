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

    def __init__(self, rest_n: np.ndarray, faces: np.ndarray, handles: np.ndarray, mu: float = 200.0,
                 handle_weights: np.ndarray | None = None):
        """rest_n: (n, 2) normalized rest positions; faces (m, 3) int64; handles (h,) int64 vertex ids;
        handle_weights: (h,) float64 >= 0 scaling mu per handle (None: 1 each, the pose term)."""
        self.n, self.faces = len(rest_n), np.asarray(faces, dtype=np.int64)
        self.handles, self.mu = np.asarray(handles, dtype=np.int64), float(mu)
        # a registration's data term trusts some vertices more than others; the pose term leaves this None so
        # its arithmetic stays what it was
        self.handle_weights = None if handle_weights is None else np.asarray(handle_weights, np.float64)[:, None]
        area = signed_areas(rest_n, self.faces)
        if (area <= 0).any():
            raise ValueError(f"rest mesh has {int((area <= 0).sum())} non-positive-area face(s)")
        self.weight = area / area.sum()
        self.coef = jacobian_coefficients(rest_n, self.faces)
        self.K = _jacobian_operator(self.coef, self.faces, self.n)
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
        if self.handle_weights is not None:
            wres = self.handle_weights * res
            E = float(np.dot(self.weight, fro * (1.0 + inv_d2)) + self.mu * (wres * res).sum())
        else:
            E = float(np.dot(self.weight, fro * (1.0 + inv_d2)) + self.mu * (res * res).sum())
            wres = res
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
        np.add.at(G, self.handles, 2.0 * self.mu * wres)
        return E, G

    def energy(self, X: np.ndarray, targets: np.ndarray) -> float:
        """Total energy at X (n, 2) with targets (h, 2), normalized."""
        return self.value_grad(X, targets, need_grad=False)[0]

    def face_hessians(self, X: np.ndarray, project: bool = True) -> np.ndarray:
        """(m, 4, 4) Hessian of each face's weighted SD term in the entries (p, q, r, s) of J_f^T at X (n, 2),
        normalized; with `project`, its positive semi-definite part.

        The projection is analytic (Smith et al. 2019, "Analytic eigensystems for isotropic distortion
        energies", 2D): of the four eigenvalues of the symmetric Dirichlet's Hessian, the two scaling ones
        (2 + 6 / sigma_i^4) and the flip one (2 + 2 (s1^2 + s1 s2 + s2^2) / (s1 s2)^3) are positive; only the
        twist one, (psi_1 + psi_2) / (s1 + s2) = 2 - 2 (|M|^2 - det) / det^3, can be negative (a face squashed
        below its rest size), with the unit eigenvector t = (-h, -e, e, -h) / (sqrt 2 sqrt(e^2 + h^2)), e and h
        the conformal part ((p + s) / 2, (r - q) / 2) of J^T. Projecting adds -lambda t t^T where lambda < 0.
        """
        M = (self.K @ X).reshape(-1, 4)
        p, q, r_, s = M.T
        det = p * s - q * r_
        fro = (M * M).sum(axis=1)
        c = np.stack([s, -r_, -q, p], axis=1)  # d det / dM
        # f = |M|^2 (1 + det^-2):
        # d2f = 2 (1 + det^-2) I - 4 det^-3 (M c^T + c M^T) + 6 |M|^2 det^-4 c c^T - 2 |M|^2 det^-3 d2det
        inv = 1.0 / det
        H = (2.0 * (1.0 + inv * inv))[:, None, None] * np.eye(4)
        Mc = M[:, :, None] * c[:, None, :]
        H -= (4.0 * inv**3)[:, None, None] * (Mc + Mc.transpose(0, 2, 1))
        H += (6.0 * fro * inv**4)[:, None, None] * (c[:, :, None] * c[:, None, :])
        H -= (2.0 * fro * inv**3)[:, None, None] * _D2_DET
        if project:
            twist = 2.0 - 2.0 * (fro - det) * inv**3
            e, h = 0.5 * (p + s), 0.5 * (r_ - q)
            t = np.stack([-h, -e, e, -h], axis=1) / np.sqrt(2.0 * (e * e + h * h))[:, None]
            H += _TWIST_FACTOR * np.maximum(-twist, 0.0)[:, None, None] * (t[:, :, None] * t[:, None, :])
        return H * self.weight[:, None, None]


_TWIST_FACTOR = 1.0
_D2_DET = np.array([[0, 0, 0, 1], [0, 0, -1, 0], [0, -1, 0, 0], [1, 0, 0, 0]], float)  # Hessian of p s - q r


def jacobian_coefficients(rest_n: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 2, 3) A with row i of J_f^T = sum_j A[f, i, j] X[faces[f, j]]: the per-face Jacobian's linear map of
    the corner positions (rows of J^T = R^-T D^T; R, D = rest and deformed edge matrices [x1-x0, x2-x0])."""
    R = np.stack([rest_n[faces[:, 1]] - rest_n[faces[:, 0]], rest_n[faces[:, 2]] - rest_n[faces[:, 0]]], axis=2)
    A = np.transpose(np.linalg.inv(R), (0, 2, 1))  # R^-T
    return np.stack([-A.sum(axis=2), A[:, :, 0], A[:, :, 1]], axis=2)


def _jacobian_operator(coef: np.ndarray, faces: np.ndarray, n: int) -> sp.csr_matrix:
    """(2m, n) sparse K with (K @ X).reshape(m, 2, 2)[f] = J_f^T, from jacobian_coefficients (m, 2, 3)."""
    m = len(faces)
    rows = np.repeat(np.arange(2 * m), 3)
    cols = np.stack([faces[:, [0, 1, 2]]] * 2, axis=1).reshape(-1)
    return sp.csr_matrix((coef.reshape(-1), (rows, cols)), shape=(2 * m, n))
