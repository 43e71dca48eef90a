"""Projected-Newton system of the symmetric Dirichlet energy plus the pose term (§4.3).

The energy's Hessian is indefinite away from the identity, so Newton's method
takes each face's 4x4 Hessian in the entries of its Jacobian, keeps its positive
semi-definite part (eigenvalues clamped at zero: the per-element projection of
Teran et al. 2005, as in Smith et al. 2019, "Analytic eigensystems for
isotropic distortion energies"), maps it to the face's six corner coordinates
and sums: a positive semi-definite (2n, 2n) matrix, positive definite once the
pose term (2 mu on every handle coordinate) pins each component that has a
handle. A handle-free component keeps its translations free (the energy does
not see them): a tiny multiple of its lumped mass on the diagonal makes the
matrix invertible there, and the caller removes the translation of the step.

The sparsity pattern is fixed per mesh: the face blocks' places in the CSC
arrays of the upper triangle are computed once, so assembling an iterate's
matrix is one bincount, and QDLDL (an LDL^T factorization from the OSQP
project, PyPI `qdldl`) orders and analyses the pattern once and only
refactorizes the numbers per iterate: 1.4 ms on a 1300-vertex template against
4.3 ms for SuperLU's full factorization. Dofs are interleaved
(x0, y0, x1, y1, ...), the layout of an (n, 2) array.
"""
from __future__ import annotations

import numpy as np
import qdldl
import scipy.sparse as sp

from ops.geometry.energy import _D2_DET, _TWIST_FACTOR, SymmetricDirichlet


class NewtonSystem:
    """The projected Hessian of one template's energy, assembled and solved per iterate."""

    def __init__(self, energy_fn: SymmetricDirichlet, diagonal: np.ndarray, project: bool = True):
        """energy_fn: the energy on the normalized rest mesh; diagonal (n,) float64 added to both coordinates
        of each vertex (2 mu per handle, the handle-free components' regularization); project: keep each face's
        positive semi-definite part (False: the true Hessian, for tests)."""
        self.energy_fn, self.project = energy_fn, project
        faces, n = energy_fn.faces, energy_fn.n
        self.size = 2 * n
        dof = (2 * faces[:, :, None] + np.arange(2)).reshape(len(faces), 6)  # (m, 6): x0 y0 x1 y1 x2 y2
        a, b = np.triu_indices(6)  # the 21 local pairs a <= b of a face's symmetric 6x6 block
        # (6, 21) selections: y @ first, y @ second = y[:, a], y[:, b] as one BLAS product (a gather is 5x slower)
        self._first, self._second = np.eye(6)[:, a], np.eye(6)[:, b]
        rows, cols = np.minimum(dof[:, a], dof[:, b]).ravel(), np.maximum(dof[:, a], dof[:, b]).ravel()
        diag = np.arange(self.size)  # the factorization reads the upper triangle only: (row <= col) per entry
        key = np.concatenate([cols, diag]).astype(np.int64) * self.size + np.concatenate([rows, diag])
        unique, self._slot = np.unique(key, return_inverse=True)  # sorted by column, then row: CSC order
        self._indices = (unique % self.size).astype(np.int32)
        self._indptr = np.searchsorted(unique // self.size, np.arange(self.size + 1)).astype(np.int32)
        self._nnz = len(unique)
        self._diagonal = np.repeat(np.asarray(diagonal, np.float64), 2)
        # the face Hessian in (p, q, r, s) is a weighted identity, a constant matrix (the Hessian of the
        # determinant) and rank-one terms; mapped to the corners by A (4, 6), the first two are constant per face
        A = _corner_map(energy_fn.coef)  # (m, 4, 6)
        self._A = A
        At = A.transpose(0, 2, 1)  # batched products: einsum's general path took 9 of an init's 22 ms
        self._AA = (At @ A)[:, a, b]  # (m, 21): A^T A
        self._AD = (At @ (_D2_DET @ A))[:, a, b]  # A^T D2 A
        self._factor: qdldl.Solver | None = None

    def matrix(self, X: np.ndarray) -> sp.csc_matrix:
        """Upper triangle (2n, 2n) CSC of the positive semi-definite Hessian at normalized positions X (n, 2).

        Per face, the symmetric Dirichlet term's Hessian in the entries M = (p, q, r, s) of J^T is
        2 (1 + det^-2) I - 4 det^-3 (M c^T + c M^T) + 6 |M|^2 det^-4 c c^T - 2 |M|^2 det^-3 D2, c = d det / dM,
        D2 = d2 det / dM2 (ops.geometry.energy.SymmetricDirichlet.face_hessians), plus the twist projection's
        -lambda t t^T; the corner block A^T H A is then two precomputed (21,) blocks scaled and outer products
        of the 6-vectors A^T M, A^T c (and A^T t where a face is twisted): no per-face 4x4 or 6x6 product."""
        ef = self.energy_fn
        M = (ef.K @ X).reshape(-1, 4)
        p, q, r_, s = M.T
        det = p * s - q * r_
        fro = (M * M).sum(axis=1)
        inv = 1.0 / det
        w = ef.weight
        first, second = self._first, self._second
        u = self._to_corners(M)
        v = self._to_corners(np.stack([s, -r_, -q, p], axis=1))
        # the rank-one terms g (u v^T + v u^T) + k v v^T = y v^T + v y^T with y = g u + k / 2 v
        cube = inv ** 3
        inv3 = w * cube
        y = (-4.0 * inv3)[:, None] * u + (3.0 * fro * inv3 * inv)[:, None] * v
        local = (2.0 * w * (1.0 + inv * inv))[:, None] * self._AA
        local -= (2.0 * fro * inv3)[:, None] * self._AD
        local += (y @ first) * (v @ second)
        local += (v @ first) * (y @ second)
        if self.project:
            twist = 2.0 - 2.0 * (fro - det) * cube
            lam = np.maximum(-twist, 0.0)
            hit = np.flatnonzero(lam)
            if len(hit):  # only faces squashed below their rest size have a negative twist eigenvalue
                e, h = 0.5 * (p[hit] + s[hit]), 0.5 * (r_[hit] - q[hit])
                t = np.stack([-h, -e, e, -h], axis=1) / np.sqrt(2.0 * (e * e + h * h))[:, None]
                z = np.einsum("fi,fia->fa", t, self._A[hit])
                local[hit] += (_TWIST_FACTOR * w[hit] * lam[hit])[:, None] * ((z @ first) * (z @ second))
        data = np.bincount(self._slot, np.concatenate([local.ravel(), self._diagonal]), minlength=self._nnz)
        return sp.csc_matrix((data, self._indices, self._indptr), shape=(self.size, self.size))

    def _to_corners(self, Y: np.ndarray) -> np.ndarray:
        """(m, 6) A^T Y for per-face vectors Y (m, 4) in (p, q, r, s): their pull-back to the corner dofs."""
        return np.einsum("fi,fia->fa", Y, self._A)

    def full_matrix(self, X: np.ndarray) -> sp.csc_matrix:
        """The whole symmetric (2n, 2n) Hessian at X (n, 2), CSC (for tests and inspection)."""
        U = self.matrix(X)
        return (U + sp.triu(U, k=1).T).tocsc()

    def step(self, X: np.ndarray, G: np.ndarray) -> np.ndarray:
        """Newton direction -H^-1 G (n, 2) at X (n, 2) for the gradient G (n, 2), all normalized; ValueError
        when the factorization meets a zero pivot (a matrix that is not positive definite)."""
        H = self.matrix(X)
        if self._factor is None:
            try:
                self._factor = qdldl.Solver(H, upper=True)
            except RuntimeError as err:  # qdldl's first factorization reports a zero pivot so, its updates by inf
                raise ValueError("the projected Hessian is singular here") from err
        else:
            self._factor.update(H, upper=True)
        D = -self._factor.solve(G.reshape(-1)).reshape(-1, 2)
        if not np.isfinite(D).all():
            raise ValueError("the projected Hessian is singular here")
        return D


def _corner_map(coef: np.ndarray) -> np.ndarray:
    """(m, 4, 6) A with (p, q, r, s) of J_f^T = A[f] @ (x0, y0, x1, y1, x2, y2), from jacobian_coefficients'
    (m, 2, 3) a: p, r = sum_j a[0 | 1, j] x_j, and q, s the same of y_j."""
    A = np.zeros((len(coef), 4, 6))
    A[:, 0, 0::2], A[:, 1, 1::2] = coef[:, 0], coef[:, 0]
    A[:, 2, 0::2], A[:, 3, 1::2] = coef[:, 1], coef[:, 1]
    return A
