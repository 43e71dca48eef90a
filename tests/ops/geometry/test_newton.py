"""Tests of ops.geometry.newton: the assembled Hessian against finite differences, and Newton's convergence."""
import numpy as np

from ops.geometry.deform import Deformer, count_flipped, first_fold_time
from ops.geometry.newton import NewtonSystem
from tests.ops.geometry.test_deform import MID, bend, strip
from tests.ops.geometry.test_energy import setup_mesh


def _system(d: Deformer, project: bool) -> NewtonSystem:
    return NewtonSystem(d.energy_fn, d._diagonal, project=project)  # project=False: the raw Hessian


def test_assembly_matches_each_face_block_mapped_to_its_corners():
    # brute force: every face's 4x4 Hessian in the entries of J^T (energy.face_hessians, itself checked against
    # finite differences) mapped to its six corner coordinates by the dense chain rule and summed, against the
    # low-rank assembly; on a mesh squashed in places (the twist projection active there) and stretched elsewhere
    res, _ = setup_mesh()
    d = Deformer(res.V, res.F, res.point_vertex)
    rng = np.random.default_rng(3)
    u = (d.rest_n[:, :1] - d.rest_n[:, 0].min()) / np.ptp(d.rest_n[:, 0])  # 0 at the left, 1 at the right
    X = d.rest_n * (0.7 + 0.7 * u) + 0.002 * rng.standard_normal(d.rest_n.shape)
    assert count_flipped(X, res.F) == 0
    coef, n = d.energy_fn.coef, len(X)
    for project in (False, True):
        H4 = d.energy_fn.face_hessians(X, project=project)
        dense = np.diag(np.repeat(d._diagonal, 2))
        for f, face in enumerate(res.F):
            A = np.zeros((4, 6))  # (p, q, r, s) = A @ (x0, y0, x1, y1, x2, y2)
            A[0, 0::2], A[1, 1::2], A[2, 0::2], A[3, 1::2] = coef[f, 0], coef[f, 0], coef[f, 1], coef[f, 1]
            dof = (2 * face[:, None] + np.arange(2)).ravel()
            dense[np.ix_(dof, dof)] += A.T @ H4[f] @ A
        got = _system(d, project).full_matrix(X).toarray()
        assert got.shape == (2 * n, 2 * n)
        assert np.abs(got - dense).max() <= 1e-12 * np.abs(dense).max()
    J = d.energy_fn.jacobians_T(X)
    det = np.linalg.det(J)
    twisted = 2.0 - 2.0 * ((J ** 2).sum(axis=(1, 2)) - det) / det ** 3 < 0
    assert 0 < twisted.sum() < len(res.F)  # both branches of the projection ran


def test_hessian_matches_finite_differences_of_the_gradient():
    V, F, h = strip()
    d = Deformer(V, F, h)
    rng = np.random.default_rng(0)
    X = d.rest_n + 0.0005 * rng.standard_normal(d.rest_n.shape)
    T = X[h] + 0.01
    H = _system(d, project=False).full_matrix(X)
    for _ in range(3):
        v = rng.standard_normal(X.shape)
        eps = 1e-6
        gp = d.energy_fn.value_grad(X + eps * v, T)[1]
        gm = d.energy_fn.value_grad(X - eps * v, T)[1]
        fd = ((gp - gm) / (2 * eps)).ravel()
        assert np.abs(H @ v.ravel() - fd).max() <= 1e-6 * np.abs(fd).max()
    assert abs(H - H.T).max() == 0.0


def test_projected_hessian_is_positive_definite_on_a_squashed_mesh():
    res, _ = setup_mesh()
    d = Deformer(res.V, res.F, res.point_vertex)
    X = d.rest_n * [0.5, 0.7]  # every face smaller than at rest: the raw Hessian is indefinite
    raw = _system(d, project=False).full_matrix(X).toarray()
    proj = _system(d, project=True).full_matrix(X).toarray()
    assert np.linalg.eigvalsh(raw).min() < 0 < np.linalg.eigvalsh(proj).min()


def test_newton_converges_in_few_iterations_to_the_same_minimum():
    V, F, h = strip()
    for degrees in (40, 120):  # 120 from rest is far: Newton meets the injectivity bound and L-BFGS steps take over
        lbfgs = Deformer(V, F, h, method="lbfgs").solve(bend(MID, degrees))
        newton = Deformer(V, F, h, method="newton").solve(bend(MID, degrees))
        assert newton.converged and count_flipped(newton.x, F) == 0
        assert np.isclose(newton.energy, lbfgs.energy, rtol=1e-5)
        assert np.abs(newton.x - lbfgs.x).max() < 0.3  # pixels: both stop at gradient norm 0.01 on a flat valley
        assert newton.iterations < lbfgs.iterations
    # warm-started from the neighbouring pose (as every frame of a lane and every warm cut candidate is)
    start = Deformer(V, F, h).solve(bend(MID, 100)).x
    lbfgs = Deformer(V, F, h, method="lbfgs").solve(bend(MID, 120), x0=start)
    newton = Deformer(V, F, h, method="newton").solve(bend(MID, 120), x0=start)
    assert np.isclose(newton.energy, lbfgs.energy, rtol=1e-5) and newton.iterations * 3 < lbfgs.iterations
    # to a tight tolerance the difference grows: Newton's steps near the minimum converge faster than linearly
    newton = Deformer(V, F, h, method="newton").solve(bend(MID, 40), grad_tol=1e-6)
    lbfgs = Deformer(V, F, h, method="lbfgs").solve(bend(MID, 40), grad_tol=1e-6)
    assert newton.converged and newton.iterations * 4 < lbfgs.iterations


def test_a_full_newton_step_is_extended_while_the_energy_keeps_falling():
    # along a quarter of the way to the minimum the energy falls past t = 1: the step doubles while it falls,
    # never past 0.8 times the first fold; along the whole way it rises past t = 1: the unit step is kept
    V, F, h = strip()
    d = Deformer(V, F, h, method="newton")
    targets = d.norm.to_norm(bend(MID, 30))
    X = d.rest_n
    best = d.norm.to_norm(d.solve(bend(MID, 30)).x)
    for fraction in (0.25, 1.0):
        D = fraction * (best - X)
        E1, G1 = d.energy_fn.value_grad(X + D, targets)
        t, E, G = d._extrapolate(X, D, targets, (1.0, E1, G1), 0.8 * first_fold_time(X, D, F))
        along = {s: d.energy_fn.value_grad(X + s * D, targets)[0] for s in (1.0, 2.0, 4.0, 8.0)}
        assert t <= 0.8 * first_fold_time(X, D, F) and E == d.energy_fn.value_grad(X + t * D, targets)[0]
        if fraction == 1.0:
            assert t == 1.0 and along[2.0] > along[1.0]
        else:
            assert t >= 2.0 and E < E1 and (2 * t not in along or along[2 * t] >= E)
        assert np.allclose(G, d.energy_fn.value_grad(X + t * D, targets)[1])


def test_a_zero_pivot_at_the_first_factorization_falls_back_to_lbfgs(monkeypatch):
    # qdldl raises RuntimeError ("not quasi-definite") when its first factorization meets a zero pivot (a handle-
    # free sliver's tiny regularizer can give one); that is a singular step, which the solver answers with
    # L-BFGS's direction, not a crash of the whole lane
    import ops.geometry.newton as newton

    class ZeroPivot:
        def __init__(self, *args, **kwargs):
            raise RuntimeError("Error in matric factorization. Input matrix is not quasi-definite")

    V, F, h = strip()
    d = Deformer(V, F, h, method="newton")
    monkeypatch.setattr(newton.qdldl, "Solver", ZeroPivot)
    res = d.solve(bend(MID, 40.0))
    assert res.converged and count_flipped(res.x, F) == 0
