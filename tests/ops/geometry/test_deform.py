"""Tests of ops.deform: injectivity bound, solver convergence without folds, free components, sequences."""
import time

import igl
import numpy as np
import pytest

from ops.geometry.deform import (
    FREE_FLOOR,
    SOLVERS,
    Deformer,
    count_flipped,
    deform_sequence,
    first_fold_time,
    max_injective_step,
)
from ops.geometry.mesh import signed_areas, triangulate_pslg
from ops.types import Template

W, H = 300.0, 60.0
MID = np.array([[x, H / 2] for x in np.linspace(10, W - 10, 7)])


def strip(offset=(0.0, 0.0)):
    """Rectangle strip mesh with handle vertices along its midline."""
    outer = np.array([[0, 0], [W, 0], [W, H], [0, H]], float) + offset
    res = triangulate_pslg([outer], W * H / 800, points=MID + offset)
    return res.V, res.F, res.point_vertex


def bend(points, degrees):
    """Rotate the right half of the points about the strip centre."""
    th = np.deg2rad(degrees)
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    c = np.array([W / 2, H / 2])
    out = points.copy()
    m = points[:, 0] > W / 2
    out[m] = c + (points[m] - c) @ R.T
    return out


def test_fold_time_hand_made_triangle():
    X = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    F = np.array([[0, 1, 2]])
    D = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, -3.0]])  # apex crosses the base at t = 1/3
    t = first_fold_time(X, D, F)
    assert np.isclose(t, 1.0 / 3.0)
    assert signed_areas(X + 0.999 * t * D, F)[0] > 0
    assert signed_areas(X + 1.001 * t * D, F)[0] < 0
    assert np.isclose(max_injective_step(X, D, F), 0.8 / 3.0)
    # Quadratic case: a rotation-like motion whose determinant has a double-root structure.
    D2 = np.array([[0.0, 0.0], [-4.0, 1.5], [1.0, -2.5]])
    t2 = first_fold_time(X, D2, F)
    assert signed_areas(X + 0.999 * t2 * D2, F)[0] > 0
    assert signed_areas(X + 1.001 * t2 * D2, F)[0] < 0
    assert max_injective_step(X, np.zeros_like(X), F) == 1.0


def test_fold_time_matches_brute_force():
    V, F, _ = strip()
    rng = np.random.default_rng(0)
    for _ in range(5):
        D = rng.standard_normal(V.shape) * 5
        t = first_fold_time(V, D, F)
        ts = np.linspace(0, min(t, 10.0) * 0.999, 400)
        assert all((signed_areas(V + s * D, F) > 0).all() for s in ts)
        if np.isfinite(t):
            assert count_flipped(V + 1.001 * t * D, F) > 0


@pytest.mark.parametrize("method", SOLVERS)
@pytest.mark.parametrize("degrees", [40, 120])
def test_solve_bent_strip(degrees, method):
    V, F, h = strip()
    d = Deformer(V, F, h, method=method)
    t0 = time.perf_counter()
    res = d.solve(bend(MID, degrees))
    elapsed = time.perf_counter() - t0
    assert res.converged and res.grad_norm < 0.01
    assert count_flipped(res.x, F) == 0
    assert np.all(np.diff(res.energy_history) <= 0)
    assert res.energy_history[0] > res.energy > 4.0
    assert np.abs(res.x[h] - bend(MID, degrees)).max() < 3.0  # handles near targets (pixels)
    assert elapsed < 5.0  # generous: the machine is shared


def test_rest_targets_are_a_fixed_point():
    V, F, h = strip()
    res = Deformer(V, F, h).solve(V[h])
    assert res.iterations == 0 and np.isclose(res.energy, 4.0) and np.allclose(res.x, V)


@pytest.mark.parametrize("method", SOLVERS)
def test_rigid_motion_is_recovered_exactly(method):
    V, F, h = strip()
    th = 0.5
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    res = Deformer(V, F, h, method=method).solve(V[h] @ R.T + [7.0, -3.0], grad_tol=1e-7)
    assert res.converged
    assert np.isclose(res.energy, 4.0, atol=1e-4)
    assert np.abs(res.x - (V @ R.T + [7.0, -3.0])).max() < 1e-3


@pytest.mark.parametrize("method", SOLVERS)
def test_component_without_handles(method):
    V1, F1, h = strip()
    V2, F2, _ = strip(offset=(0.0, 200.0))
    V = np.concatenate([V1, V2])
    F = np.concatenate([F1, F2 + len(V1)])
    d = Deformer(V, F, h, method=method)
    res = d.solve(bend(MID, 60))
    assert res.converged
    assert count_flipped(res.x, F) == 0
    free = slice(len(V1), None)
    # The handle-free piece has no reason to move: it stays rigid (identity) and does not drift.
    assert np.abs(res.x[free] - V2).max() < 1e-6
    single = Deformer(V1, F1, h, method=method).solve(bend(MID, 60))
    # Doubling the area halves every normalized term of the first strip; the free one adds 4 * 1/2.
    assert np.isclose(res.energy, 0.5 * single.energy + 2.0, rtol=1e-4)


@pytest.mark.parametrize("method", SOLVERS)
def test_a_handle_free_sliver_component_solves(method):
    """A lone face of 1.5e-7 px^2 with no handle (overlapping painted regions cut it off, and a lane's
    registration starts from where the frame squashed it; h01's true masks): its lumped mass vanishes against its
    cotangent weights, and the system was exactly singular. It solves, folds nothing and stays where it is."""
    V1, F1, h = strip()
    sliver = np.array([[85.0, 101.0], [85.00096902096588, 100.9998788691448],
                       [85.00052318446612, 101.00024881817635]])
    V = np.concatenate([V1, sliver])
    F = np.concatenate([F1, [[len(V1) + 1, len(V1) + 2, len(V1)]]])
    assert signed_areas(V, F).min() > 0
    d = Deformer(V, F, h, method=method)
    # its regularizer keeps up with its cotangent weights (there the system was singular, by rounding's luck)
    cot = -igl.cotmatrix(d.rest_n, d.faces).diagonal()[len(V1):]
    assert (d._diagonal[len(V1):] >= FREE_FLOOR * cot * (1 - 1e-9)).all() and cot.min() > 0.1
    res = d.solve(bend(MID, 30))
    assert count_flipped(res.x, F) == 0
    assert np.abs(res.x[len(V1):] - sliver).max() < 1e-6


def test_folded_start_raises():
    V, F, h = strip()
    X = V.copy()
    X[:, 0] *= -1
    with pytest.raises(ValueError):
        Deformer(V, F, h).solve(V[h], x0=X)


def strip_template(V, F, h) -> Template:
    """The strip as a single-layer template with one handle per midline point, each its own joint."""
    J = len(h)
    return Template(
        rest=V, faces=F, face_layer=np.zeros(len(F), np.int64), handles=h, handle_weights=np.eye(J),
        handle_offsets=np.zeros((J, 2)), handle_frames=np.full((J, 2), -1),
        cut_assignment=[], energy=0.0, trials=1, mode="single-layer",
    )


def test_deform_sequence_orders():
    V, F, h = strip()
    J = len(MID)
    tpl = strip_template(V, F, h)
    poses = np.stack([np.concatenate([bend(MID, a), np.zeros((J, 1))], 1) for a in (0, 30, 60)])
    Xf, Ef, If = deform_sequence(tpl, poses, "forward")
    Xb, Eb, Ib = deform_sequence(tpl, poses, "backward")
    assert Xf.shape == (3, len(V), 2) and Ef.shape == (3,) and If.dtype == np.int64
    assert If[0] == 0 and np.allclose(Xf[0], V)  # key0's template starts at its own rest pose
    assert np.isclose(Ef[0], 4.0)
    for X in list(Xf) + list(Xb):
        assert count_flipped(X, F) == 0
    # Both orders reach the same minimiser of this convex-ish problem closely.
    assert np.abs(Xf[2] - Xb[2]).max() < 1.0
    with pytest.raises(ValueError):
        deform_sequence(tpl, poses, "sideways")


def test_frames_by_newton_reach_the_lbfgs_energies_in_fewer_iterations():
    """The lanes' frames (FRAME_METHOD, stopped at FRAME_GRAD_TOL) reach the energy L-BFGS stops at, or a lower one,
    per frame, fold-free, in fewer iterations; stopped at L-BFGS's gradient norm instead, Newton halts above it on
    a bend's flat valley."""
    V, F, h = strip()
    J = len(MID)
    tpl = strip_template(V, F, h)
    poses = np.stack([np.concatenate([bend(MID, a), np.zeros((J, 1))], 1) for a in np.linspace(0, 120, 7)])
    X_newton, E_newton, it_newton = deform_sequence(tpl, poses)
    _, E_lbfgs, it_lbfgs = deform_sequence(tpl, poses, deformer=Deformer(V, F, h, method="lbfgs"))
    assert (E_newton <= E_lbfgs + 1e-7).all()
    assert it_newton.sum() < it_lbfgs.sum() / 2
    assert all(count_flipped(X, F) == 0 for X in X_newton)
    _, E_early, _ = deform_sequence(tpl, poses, grad_tol=0.01)
    assert (E_early > E_lbfgs + 1e-6).any()


def test_one_solve_recursion_equals_the_textbook_two_loop():
    # the solver applies P^-1 once per iteration and forms P^-1 y from consecutive preconditioned gradients;
    # the textbook recursion (P^-1 applied to q after the first loop, and to y for the scaling) must agree,
    # on a mesh with a handle-free piece (whose translation the preconditioner projects out)
    V1, F1, h = strip()
    V2, F2, _ = strip(offset=(0.0, 100.0))
    V, F = np.vstack([V1, V2]), np.vstack([F1, F2 + len(V1)])
    d = Deformer(V, F, h)
    assert len(d._free_groups) == 1
    rng = np.random.default_rng(1)
    G = [rng.standard_normal(V.shape) for _ in range(5)]
    S = [rng.standard_normal(V.shape) for _ in range(4)]
    hist, textbook = [], []
    for i in range(4):
        y = G[i + 1] - G[i]
        hist.append((S[i], y, 1.0 / np.vdot(S[i], y), d.precondition(G[i + 1]) - d.precondition(G[i])))
        textbook.append((S[i], y, 1.0 / np.vdot(S[i], y)))
    q, alphas = G[4].copy(), []
    for s, y, rho in reversed(textbook):
        alphas.append(rho * np.vdot(s, q))
        q -= alphas[-1] * y
    r = d.precondition(q) * np.vdot(S[3], textbook[3][1]) / np.vdot(textbook[3][1], d.precondition(textbook[3][1]))
    for (s, y, rho), a in zip(textbook, reversed(alphas)):
        r += (a - rho * np.vdot(y, r)) * s
    fast = d._direction(G[4], d.precondition(G[4]), hist)
    # equal up to the rounding of the solves (the free piece's regularized P is ill-conditioned: ~1e-8)
    assert np.abs(fast - r).max() <= 1e-7 * np.abs(r).max()
    # and the projection: the free piece's mean of P^-1 G is zero, its other part is the plain solve's
    PG = d.precondition(G[0])
    assert np.allclose(PG[len(V1):].mean(axis=0), 0.0, atol=1e-6)  # (its translation before: ~1e6 x larger)
    assert np.allclose(PG[:len(V1)], d._preconditioner()(G[0])[:len(V1)])
