"""Tests of ops.energy: identity value, invariances, finite-difference gradient."""
import numpy as np

from ops.geometry.energy import SymmetricDirichlet, normalization
from ops.geometry.mesh import signed_areas, triangulate_pslg


def setup_mesh(seed=0):
    outer = np.array([[0, 0], [120, 0], [120, 40], [60, 70], [0, 40]], float)
    pts = np.array([[20.0, 20.0], [60.0, 30.0], [100.0, 20.0]])
    res = triangulate_pslg([outer], 40.0, points=pts)
    nrm = normalization(res.V, res.F)
    return res, nrm


def test_normalization_unit_area():
    res, nrm = setup_mesh()
    Xn = nrm.to_norm(res.V)
    assert np.isclose(signed_areas(Xn, res.F).sum(), 1.0)
    assert np.allclose(nrm.to_pixels(Xn), res.V)


def test_identity_energy_is_four():
    res, nrm = setup_mesh()
    Xn = nrm.to_norm(res.V)
    e = SymmetricDirichlet(Xn, res.F, res.point_vertex, mu=200.0)
    assert np.isclose(e.energy(Xn, Xn[res.point_vertex]), 4.0, atol=1e-12)
    E, G = e.value_grad(Xn, Xn[res.point_vertex])
    assert np.abs(G).max() < 1e-10  # identity is the minimum


def test_rotation_and_translation_invariance():
    res, nrm = setup_mesh()
    Xn = nrm.to_norm(res.V)
    h = res.point_vertex
    e = SymmetricDirichlet(Xn, res.F, h)
    rng = np.random.default_rng(1)
    X = Xn + 0.002 * rng.standard_normal(Xn.shape)
    T = Xn[h] + 0.01
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    sd = e.energy(X, X[h])
    assert np.isclose(e.energy(X @ R.T + 3.0, X[h] @ R.T + 3.0), sd, rtol=1e-12)
    assert sd > 4.0
    assert np.isclose(e.energy(X @ R.T, T @ R.T), e.energy(X, T), rtol=1e-12)


def test_scaling_identity_analytic():
    # Uniform scale s: ||J||^2 = 2 s^2, ||J^-1||^2 = 2 / s^2.
    res, nrm = setup_mesh()
    Xn = nrm.to_norm(res.V)
    e = SymmetricDirichlet(Xn, res.F, np.zeros(0, np.int64))
    for s in (0.5, 1.3):
        assert np.isclose(e.energy(s * Xn, np.zeros((0, 2))), 2 * s**2 + 2 / s**2)


def test_gradient_finite_differences():
    res, nrm = setup_mesh()
    Xn = nrm.to_norm(res.V)
    h = res.point_vertex
    e = SymmetricDirichlet(Xn, res.F, h, mu=200.0)
    rng = np.random.default_rng(2)
    X = Xn + 0.003 * rng.standard_normal(Xn.shape)
    assert (signed_areas(X, res.F) > 0).all()
    T = Xn[h] + 0.05 * rng.standard_normal((len(h), 2))
    E, G = e.value_grad(X, T)
    for _ in range(5):
        D = rng.standard_normal(X.shape)
        eps = 1e-6
        fd = (e.energy(X + eps * D, T) - e.energy(X - eps * D, T)) / (2 * eps)
        an = float(np.vdot(G, D))
        assert abs(fd - an) / abs(an) < 1e-5
    # Per-coordinate check on a few entries.
    for i in rng.choice(len(X), 6, replace=False):
        for c in range(2):
            D = np.zeros_like(X)
            D[i, c] = 1.0
            fd = (e.energy(X + 1e-7 * D, T) - e.energy(X - 1e-7 * D, T)) / 2e-7
            assert abs(fd - G[i, c]) <= 1e-5 * max(abs(G[i, c]), 1e-3 * np.abs(G).max())


def test_folded_is_infinite():
    res, nrm = setup_mesh()
    Xn = nrm.to_norm(res.V)
    e = SymmetricDirichlet(Xn, res.F, res.point_vertex)
    X = Xn.copy()
    X[:, 0] *= -1  # mirror: every face inverted
    assert e.energy(X, X[res.point_vertex]) == np.inf


def test_face_hessians_match_finite_differences_of_the_gradient():
    res, nrm = setup_mesh()
    Xn = nrm.to_norm(res.V)
    e = SymmetricDirichlet(Xn, res.F, res.point_vertex)
    X = Xn + 0.003 * np.random.default_rng(2).standard_normal(Xn.shape)
    H = e.face_hessians(X, project=False)
    eps, M = 1e-6, (e.K @ X).reshape(-1, 4)
    fd = np.zeros_like(H)
    for i in range(4):
        dM = np.zeros_like(M)
        dM[:, i] = eps
        # the face gradient as a function of M: evaluate through a K-free copy of the formula
        plus = _grad_of_M(e, M + dM)
        minus = _grad_of_M(e, M - dM)
        fd[:, :, i] = (plus - minus) / (2 * eps)
    assert np.abs(fd - H).max() <= 1e-6 * np.abs(H).max()
    assert np.allclose(H, H.transpose(0, 2, 1))


def _grad_of_M(e: SymmetricDirichlet, M: np.ndarray) -> np.ndarray:
    p, q, r, s = M.T
    det = p * s - q * r
    fro = (M * M).sum(1)
    return ((2 * (1 + det**-2))[:, None] * M - (2 * fro * det**-3)[:, None] * np.stack([s, -r, -q, p], 1)) \
        * e.weight[:, None]


def test_analytic_projection_equals_clamped_eigendecomposition():
    # squashed, stretched and sheared faces: the twist eigenvalue goes negative where a face is compressed
    res, nrm = setup_mesh()
    Xn = nrm.to_norm(res.V)
    e = SymmetricDirichlet(Xn, res.F, res.point_vertex)
    rng = np.random.default_rng(3)
    for scale in (0.4, 0.8, 1.0, 1.7):
        X = Xn * [scale, 1.0 / scale**0.3] + 0.002 * rng.standard_normal(Xn.shape)
        raw, proj = e.face_hessians(X, project=False), e.face_hessians(X)
        lam, Q = np.linalg.eigh(raw)
        clamped = np.einsum("fij,fj,fkj->fik", Q, np.maximum(lam, 0.0), Q)
        assert np.abs(proj - clamped).max() <= 1e-9 * np.abs(raw).max()
        assert np.linalg.eigvalsh(proj).min() >= -1e-12 * np.abs(raw).max()
    assert (np.linalg.eigvalsh(e.face_hessians(Xn * 0.5, project=False)).min(axis=1) < 0).all()  # squashed: indefinite
