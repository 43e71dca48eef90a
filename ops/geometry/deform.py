"""Injective skeleton-driven deformation of a template mesh (§4.3).

Minimizes the symmetric Dirichlet energy plus the pose term (ops.energy) by
one of two descent methods (Deformer's `method`), both with the same
injectivity-capped line search:

- "newton" (the cut search's, ops.geometry.topology.Solver): projected Newton
  steps (ops.geometry.newton: each face's Hessian projected to positive
  semi-definite, the sparse system refactorized per iterate). Where the
  injectivity bound would cut a Newton step below its newton_cap (0.3; the
  cut search's 0.1, SEARCH_NEWTON_CAP) the step is L-BFGS's instead, for 1,
  2, 4 .. MAX_BACKOFF iterations before Newton is tried again: far from a
  minimum (a pose far from the start) Newton aims through folds and then
  creeps along the barrier into a crumpled minimum (the tail's direct solve
  to its curled pose: 920 steps to an energy of 289), where the
  Laplacian-preconditioned direction moves the whole sheet smoothly.
  Near a minimum (each warm cut candidate) it takes 5-15x fewer iterations.
  A full Newton step the line search accepts is doubled while the energy keeps
  falling (within the injectivity bound): where a limb swings, the
  linearized step undershoots the arc the vertices move along, and Newton
  crept there at full steps (arm_cross key1's losing cuts: 25-40 iterations
  each to the other pose); over the samples' cut searches 4197 -> 3254
  iterations, one near-tie cusp one vertex over (scan_jpeg key0, energies
  within 1e-6).
  The lanes' frames (FRAME_METHOD, deform_sequence), each from its
  neighbour's solution, stopped at FRAME_GRAD_TOL: with the usual gradient
  norm of 0.01 it halted on a frame's flat valley short of the minimum L-BFGS
  reaches (arm_cross key0's last frame: 3.7 px off, energy 4.7548 against
  4.7534, 0.11 dB in the evaluation; the true Hessian is positive definite
  there, no saddle). Not the lanes' direct solves from rest to the other key
  pose: those land in other crumpled minima with it (docs/performance.md).
- "lbfgs" (Deformer's default: the lanes' direct solves to the other key): the
  Laplacian-preconditioned L-BFGS, whose steps "newton" borrows. The two-loop
  recursion uses the factorized matrix P = 8 (-L) + 2 mu H as initial inverse
  Hessian (L = cotangent Laplacian of the normalized rest mesh, H = handle
  indicator; 8 (-L) is the SD Hessian scale at the identity, 2 mu that of the
  pose term), scaled each iteration by s^T y / y^T P^-1 y. P is factorized
  once per mesh (splu). One solve with P per iteration: applying P^-1 is
  linear, so the recursion's P^-1 q = P^-1 g - sum a_i P^-1 y_i is assembled
  from the preconditioned gradient of each iterate and
  P^-1 y_i = P^-1 g_(i+1) - P^-1 g_i, kept with its pair. Every step of
  either method updates the pairs.

Connected components without a handle make both systems singular (translations
are free): those vertices get a tiny multiple of the lumped mass matrix on the
diagonal, and every search direction has its per-component mean removed there
(the SD gradient sums to zero per component, so this stays a descent
direction and never drifts the free piece).

Every line search starts at min(1, 0.8 * first-fold time) along the
direction (Smith & Schaefer 2015), then halves until Armijo (c1 = 1e-4)
holds, so no iterate ever folds a triangle.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import igl
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ops.geometry.energy import SymmetricDirichlet, normalization
from ops.geometry.mesh import signed_areas, vertex_components
from ops.geometry.newton import NewtonSystem
from ops.types import Template


@dataclass
class DeformResult:
    """Outcome of one Deformer.solve call."""

    x: np.ndarray  # (n, 2) float64 deformed positions, pixels
    energy: float  # final total energy (normalized units; identity SD part = 4)
    iterations: int
    grad_norm: float  # ||dE/dx|| in normalized coordinates
    converged: bool
    energy_history: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (iterations + 1,) energy per iterate
    path_x: list = field(default_factory=list)  # solve_along: (n, 2) pixels reached at each step of its path
    path_energy: list = field(default_factory=list)  # solve_along: the energy at each step of its path


def count_flipped(X: np.ndarray, F: np.ndarray) -> int:
    """Number of faces F (m, 3) with signed area <= 0 at positions X (n, 2)."""
    return int((signed_areas(np.asarray(X, dtype=np.float64), F) <= 0).sum())


def first_fold_time(X: np.ndarray, D: np.ndarray, faces: np.ndarray) -> float:
    """Smallest t > 0 at which a face's signed area reaches 0 along X + t D (both (n, 2)); inf if none."""
    e = np.stack([X[faces[:, 1]] - X[faces[:, 0]], X[faces[:, 2]] - X[faces[:, 0]]], axis=1)
    f = np.stack([D[faces[:, 1]] - D[faces[:, 0]], D[faces[:, 2]] - D[faces[:, 0]]], axis=1)
    return _fold_time(e, f)


def _fold_time(e: np.ndarray, f: np.ndarray) -> float:
    """First t > 0 with det(e + t f) = 0 over faces; e, f (m, 2, 2) rows = edge vectors (x1-x0, x2-x0)."""

    def cross(u, v):
        """Determinant-like bilinear term u00 v11 - u01 v10 per face."""
        return u[:, 0, 0] * v[:, 1, 1] - u[:, 0, 1] * v[:, 1, 0]

    # det(e + t f) = qa t^2 + qb t + qc
    qa, qc = cross(f, f), cross(e, e)
    qb = cross(e, f) + cross(f, e)
    t = np.full(len(e), np.inf)
    lin = np.abs(qa) <= 1e-14 * (np.abs(qb) + np.abs(qc) + 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        tl = -qc / qb
        t = np.where(lin & (tl > 0), tl, t)
        disc = qb * qb - 4.0 * qa * qc
        ok = ~lin & (disc >= 0)
        # Numerically stable pair of roots: q / a and c / q.
        q = -0.5 * (qb + np.copysign(np.sqrt(np.maximum(disc, 0.0)), qb))
        r1, r2 = q / qa, qc / q
        r1 = np.where(ok & (r1 > 0), r1, np.inf)
        r2 = np.where(ok & (r2 > 0), r2, np.inf)
        t = np.minimum(t, np.minimum(r1, r2))
    return float(t.min()) if len(t) else np.inf


def max_injective_step(X: np.ndarray, D: np.ndarray, faces: np.ndarray) -> float:
    """Step in (0, 1]: min(1, 0.8 * first_fold_time) along X + t D, which keeps every face positive."""
    return float(min(1.0, 0.8 * first_fold_time(X, D, faces)))


SOLVERS = ("newton", "lbfgs")  # Deformer's methods: projected Newton (the cut search's), preconditioned L-BFGS
# A lane's frames: projected Newton stopped at a tenth of the usual gradient norm (why: the module docstring). At
# 1e-3 it reaches L-BFGS's energy or a lower one on 64 of 72 lanes (samples, held-out, realdev) in 0.27x its CPU
# time over all of them; the other eight settle in other minima of hard, crumpled frames (docs/performance.md).
FRAME_METHOD, FRAME_GRAD_TOL = "newton", 1e-3
# "newton" takes L-BFGS steps where the injectivity bound cuts a Newton step below this (Deformer's newton_cap).
# The lanes' frames keep 0.3. The cut search takes SEARCH_NEWTON_CAP (ops.geometry.topology.Solver): over the
# samples' cut searches 0.1 takes 1410 iterations where 0.3 took 2737 (hand_on_hip key1 1200 -> 253), every cut
# the same and every winner's energy to 1e-6 (hand_on_hip key1 5.478376 -> 5.478136); curled_tail's key1 with
# five more T-junctions 77-483 -> 44-52 a candidate: short Newton steps along the barrier beat L-BFGS's there.
# The lanes' frames at 0.1 took the same iterations (1536 -> 1534 over the samples) and moved no evaluated shot by
# more than 0.02 dB: nothing to gain, so they keep 0.3.
NEWTON_CAP, SEARCH_NEWTON_CAP = 0.3, 0.1
FREE_FLOOR = 1e-14  # a handle-free vertex's regularizer, at least this share of its cotangent diagonal
MAX_BACKOFF = 16  # 1, 2, 4, .. up to this many before trying Newton again (over the samples: a cap of 0.3 and
#                   16 kept the direct solves' L-BFGS minima; 0.5 and 64 cost the cut search up to 2.5x more L-BFGS steps)


class Deformer:
    """Prepares one template's energy once; `solve` deforms it to handle targets (projected Newton or L-BFGS)."""

    def __init__(self, rest: np.ndarray, faces: np.ndarray, handles: np.ndarray, mu: float = 200.0,
                 method: str = "lbfgs", handle_weights: np.ndarray | None = None, newton_cap: float = NEWTON_CAP):
        """rest (n, 2) float64 pixels, faces (m, 3) int64 positive area, handles (h,) int64 vertex ids;
        method: one of SOLVERS; handle_weights (h,) scale mu per handle (None: 1 each)."""
        if method not in SOLVERS:
            raise ValueError(f"method must be one of {SOLVERS}, got {method!r}")
        self.rest = np.asarray(rest, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)
        self.handles = np.asarray(handles, dtype=np.int64)
        self.method, self.mu, self.newton_cap = method, float(mu), float(newton_cap)
        self.norm = normalization(self.rest, self.faces)
        self.rest_n = self.norm.to_norm(self.rest)
        self.energy_fn = SymmetricDirichlet(self.rest_n, self.faces, self.handles, mu, handle_weights)
        self._laplacian = None  # -cotmatrix of the normalized rest mesh, made when first needed
        self._setup_free_groups()
        self._edges = _edge_operator(self.faces, len(self.rest))
        self._newton: NewtonSystem | None = None
        self._solve_P = None  # the L-BFGS preconditioner's factorization, made when first needed

    def _setup_free_groups(self) -> None:
        """Label the vertices of components without handles, whose mean is projected out of every step, and the
        diagonal both systems add: 2 mu per handle, a tiny multiple of the lumped mass on handle-free vertices (at
        least FREE_FLOOR of their cotangent diagonal)."""
        n = len(self.rest_n)
        comp = vertex_components(n, self.faces)
        has_handle = np.zeros(comp.max() + 1, bool)
        has_handle[comp[self.handles]] = True
        free = ~has_handle[comp]
        # each vertex of a handle-free component -> its group 0 .. g-1 (the others are never projected)
        group_of = np.full(comp.max() + 1, -1, np.int64)
        group_of[~has_handle] = np.arange(int((~has_handle).sum()))
        self._free = np.nonzero(free)[0]
        self._group = group_of[comp[self._free]]
        self._group_size = np.bincount(self._group).astype(np.float64)
        hw = self.energy_fn.handle_weights
        self._diagonal = np.bincount(self.handles, None if hw is None else hw[:, 0], minlength=n) * 2.0 * self.mu
        if free.any():
            mass = np.zeros(n)
            np.add.at(mass, self.faces.ravel(), np.repeat(self.energy_fn.weight / 3.0, 3))
            mass = np.where(mass > 0, mass, 1.0 / max(n, 1))
            # the cotangent weights do not shrink with a face: a handle-free sliver (one face of 1.5e-7 px^2 cut
            # off by overlapping painted regions) had a mass so small against them that the system was exactly
            # singular, so its regularizer is at least FREE_FLOOR of its cotangent diagonal
            cot = self._cot_laplacian().diagonal()
            self._diagonal += np.maximum(1e-6 * mass, FREE_FLOOR * np.abs(cot)) * free

    def _cot_laplacian(self):
        """(n, n) sparse -L, the cotangent Laplacian of the normalized rest mesh (positive semidefinite)."""
        if self._laplacian is None:
            self._laplacian = -igl.cotmatrix(self.rest_n, self.faces)
        return self._laplacian

    def _preconditioner(self):
        """Factorize P = 8 (-L) + the diagonal once (L-BFGS's initial inverse Hessian): its solve function."""
        if self._solve_P is None:
            L = self._cot_laplacian()
            self._solve_P = splu(sp.csc_matrix(8.0 * L + sp.diags(self._diagonal))).solve
        return self._solve_P

    @property
    def _free_groups(self) -> list[np.ndarray]:
        """The vertex ids of each handle-free component."""
        return [self._free[self._group == g] for g in range(len(self._group_size))]

    def precondition(self, G: np.ndarray) -> np.ndarray:
        """P^-1 G for G (n, 2), with handle-free components' translation removed (a linear map of G)."""
        return self._remove_free_translation(self._preconditioner()(G))

    def _remove_free_translation(self, D: np.ndarray) -> np.ndarray:
        """D (n, 2) with each handle-free component's mean removed, in place."""
        if len(self._free):
            mean = np.stack([np.bincount(self._group, D[self._free, c]) for c in (0, 1)], axis=1)
            D[self._free] -= (mean / self._group_size[:, None])[self._group]
        return D

    def energy(self, x: np.ndarray, targets: np.ndarray) -> float:
        """Total energy of positions x (n, 2) pixels with handle targets (h, 2) pixels."""
        return self.energy_fn.energy(self.norm.to_norm(x), self.norm.to_norm(targets))

    def solve(
        self,
        targets: np.ndarray,
        x0: np.ndarray | None = None,
        grad_tol: float = 0.01,
        max_iter: int = 5000,
        memory: int = 10,
        method: str | None = None,
    ) -> DeformResult:
        """Minimize energy for handle targets (h, 2) pixels from fold-free x0 (n, 2) pixels (rest if None).

        Stops at gradient norm grad_tol (normalized units) or after max_iter iterations; memory: the L-BFGS
        pairs kept (both methods keep them: "newton" takes L-BFGS steps at the injectivity barrier); method: one
        of SOLVERS for this solve (default: the Deformer's)."""
        T = self.norm.to_norm(targets)
        X = self.rest_n.copy() if x0 is None else self.norm.to_norm(x0)
        E, G = self.energy_fn.value_grad(X, T)
        if not np.isfinite(E):
            raise ValueError("x0 folds a triangle: the deformation must start from a fold-free state")
        method = method or self.method
        if method not in SOLVERS:
            raise ValueError(f"method must be one of {SOLVERS}, got {method!r}")
        X, E, G, energies = self._iterations(X, E, G, T, grad_tol, max_iter, memory, method)
        gnorm = float(np.linalg.norm(G))
        return DeformResult(
            x=self.norm.to_pixels(X),
            energy=float(E),
            iterations=len(energies) - 1,
            grad_norm=gnorm,
            converged=gnorm < grad_tol,
            energy_history=np.asarray(energies),
        )

    def _iterations(self, X, E, G, T, grad_tol: float, max_iter: int, memory: int, method: str):
        """Descend from (X, E, G) at normalized targets T until |G| < grad_tol: (X, E, G, energies per iterate).

        Every step updates the L-BFGS pairs. "lbfgs" steps along the L-BFGS direction; "newton" along the
        projected Newton direction (ops.geometry.newton), except where the injectivity bound would cut that
        step below self.newton_cap: far from a minimum (a pose far from the start) Newton aims past folds and then
        creeps along the barrier in tiny steps (the tail's direct solve to its curled pose: 920 steps to an
        energy of 289), where the Laplacian-preconditioned direction moves the whole sheet smoothly. A step the
        line search rejects is retried along the preconditioned gradient, with the pairs cleared.
        """
        hist = deque(maxlen=memory)  # [s, y, 1 / s.y, P^-1 y] of the newest pairs (P^-1 y None until needed)
        energies = [E]
        gnorm = float(np.linalg.norm(G))
        # P^-1 G of the current iterate: every iteration for "lbfgs" (its pairs' P^-1 y come from consecutive
        # ones), only when an L-BFGS step is taken for "newton" (most of its solves never factorize P at all)
        eager = method == "lbfgs"
        PG = self.precondition(G) if eager and gnorm >= grad_tol else None
        lbfgs_left, backoff = 0, 0  # L-BFGS steps to take before Newton is tried again, and how many next time
        while gnorm >= grad_tol and len(energies) <= max_iter:
            D, cap, newton_step = None, 0.0, False
            if not eager and lbfgs_left == 0:
                D, reach = self._newton_direction(X, G)
                cap = min(1.0, reach)
                if cap < self.newton_cap:  # Newton meets the barrier: L-BFGS for a while, longer each time in a row
                    backoff = min(2 * backoff or 1, MAX_BACKOFF)
                    lbfgs_left = backoff
                else:
                    backoff, newton_step = 0, True
            elif lbfgs_left:
                lbfgs_left -= 1
            if D is None or cap < self.newton_cap:
                PG = self.precondition(G) if PG is None else PG
                D = -self._direction(G, PG, hist)
                if np.vdot(D, G) >= 0:  # not a descent direction: restart from the preconditioned gradient
                    hist.clear()
                    D = -PG
                cap = self._injective_step(X, D)
            step = self._line_search(X, D, E, G, T, cap)
            if step is not None and newton_step and step[0] == 1.0:
                step = self._extrapolate(X, D, T, step, reach)
            if step is None and (hist or not eager):
                hist.clear()
                PG = self.precondition(G) if PG is None else PG
                D = -PG
                step = self._line_search(X, D, E, G, T, self._injective_step(X, D))
            if step is None:
                break
            t, E1, G1 = step
            PG1 = self.precondition(G1) if eager else None
            s, y = t * D, G1 - G
            if np.vdot(s, y) > 1e-16:
                hist.append([s, y, 1.0 / np.vdot(s, y), PG1 - PG if eager else None])
            X, E, G, PG = X + s, E1, G1, PG1
            energies.append(E)
            gnorm = float(np.linalg.norm(G))
        return X, E, G, energies

    def _newton_direction(self, X: np.ndarray, G: np.ndarray) -> tuple[np.ndarray | None, float]:
        """(projected Newton direction (n, 2), 0.8 times its first fold time: the longest step injectivity allows),
        or (None, 0) where the projected Hessian is singular or the direction does not descend."""
        if self._newton is None:
            self._newton = NewtonSystem(self.energy_fn, self._diagonal)
        try:
            D = self._remove_free_translation(self._newton.step(X, G))
        except ValueError:
            return None, 0.0
        if np.vdot(D, G) >= 0:
            return None, 0.0
        return D, 0.8 * self._fold_time(X, D)

    def solve_along(
        self,
        path: list[np.ndarray],
        x0: np.ndarray | None = None,
        grad_tol: float = 0.01,
        step_tol: float = 1.0,
        max_iter: int = 5000,
    ) -> DeformResult:
        """Continuation: solve to each handle-target set of `path` (each (h, 2) pixels) in turn, each from the
        previous solution; the intermediate ones only to gradient norm step_tol, the last to grad_tol.

        A direct solve from rest to a far pose starts where the pose term dwarfs everything else, and L-BFGS can
        settle in a crumpled minimum after thousands of iterations (over the samples' topologies: 163k iterations
        in all, energies up to 7x those of this path); a few steps along the motion reach the minimum the lanes'
        frame-by-frame deformation reaches, in a third of the iterations. Returns the last solve, with
        iterations and the energy history of all steps, and the positions and energy reached at each step.
        """
        if not len(path):
            raise ValueError("solve_along needs at least one set of handle targets")
        x, iterations, history, xs, energies = x0, 0, [], [], []
        for i, targets in enumerate(path):
            res = self.solve(targets, x0=x, grad_tol=grad_tol if i == len(path) - 1 else step_tol, max_iter=max_iter)
            x, iterations = res.x, iterations + res.iterations
            history.append(res.energy_history)
            xs.append(res.x)
            energies.append(res.energy)
        res.iterations, res.energy_history = iterations, np.concatenate(history)
        res.path_x, res.path_energy = xs, energies
        return res

    def _direction(self, G: np.ndarray, PG: np.ndarray, hist: deque) -> np.ndarray:
        """L-BFGS two-loop recursion with H0 = gamma P^-1: approximates H^-1 G, (n, 2); PG = P^-1 G."""
        for pair in hist:  # pairs of Newton steps: their P^-1 y, once
            if pair[3] is None:
                pair[3] = self.precondition(pair[1])
        q, r = G.copy(), PG.copy()  # r follows P^-1 q through the first loop (P^-1 is linear)
        alphas = []
        for s, y, rho, Py in reversed(hist):
            a = rho * np.vdot(s, q)
            alphas.append(a)
            q -= a * y
            r -= a * Py
        if hist:
            # Standard L-BFGS scaling of H0 = gamma P^-1 from the newest pair.
            s, y, _, Py = hist[-1]
            r *= np.vdot(s, y) / max(np.vdot(y, Py), 1e-300)
        for (s, y, rho, _), a in zip(hist, reversed(alphas)):
            b = rho * np.vdot(y, r)
            r += (a - b) * s
        return r

    def _injective_step(self, X: np.ndarray, D: np.ndarray) -> float:
        """min(1, 0.8 * first-fold time) along X + t D, both (n, 2) normalized (max_injective_step, faster)."""
        return float(min(1.0, 0.8 * self._fold_time(X, D)))

    def _fold_time(self, X: np.ndarray, D: np.ndarray) -> float:
        """First t > 0 at which a face folds along X + t D, both (n, 2) normalized (first_fold_time, faster)."""
        m = len(self.faces)
        return _fold_time((self._edges @ X).reshape(m, 2, 2), (self._edges @ D).reshape(m, 2, 2))

    def _extrapolate(self, X, D, T, step, cap: float):
        """A full Newton step accepted: (t, E, G) at the lowest energy of t = 2, 4, .. along D while it keeps
        falling, each t capped at `cap` (0.8 times the first fold time along D)."""
        t = step[0]
        while min(2.0 * t, cap) > 1.01 * t:
            t2 = min(2.0 * t, cap)
            E2, G2 = self.energy_fn.value_grad(X + t2 * D, T)
            if not E2 < step[1]:
                break
            step, t = (t2, E2, G2), t2
        return step

    def _line_search(self, X, D, E, G, T, t: float, c1: float = 1e-4, max_halvings: int = 40):
        """Backtracking Armijo search from the injectivity-capped step t: (t, E, G) or None."""
        slope = float(np.vdot(G, D))
        for _ in range(max_halvings):
            Xt = X + t * D
            Et, Gt = self.energy_fn.value_grad(Xt, T)
            if Et <= E + c1 * t * slope:
                return t, Et, Gt
            t *= 0.5
        return None


def _edge_operator(faces: np.ndarray, n: int) -> sp.csr_matrix:
    """(2m, n) sparse: (E @ X).reshape(m, 2, 2)[f] = rows (x1 - x0, x2 - x0) of face f."""
    m = len(faces)
    rows = np.repeat(np.arange(2 * m), 2)
    cols = np.stack([faces[:, [1, 0]], faces[:, [2, 0]]], axis=1).reshape(-1)
    vals = np.tile([1.0, -1.0], 2 * m)
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * m, n))


def deform_sequence(
    template: Template, poses: np.ndarray, order: str = "forward", deformer: Deformer | None = None,
    grad_tol: float | None = None, mu: float = 200.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Deform the template into every pose (T, J, 3), warm-starting each frame from its neighbour.

    order "forward" solves t = 0, 1, ... (key0's template); "backward" solves
    from the last frame down (key1's). deformer: default FRAME_METHOD's with
    pose weight mu; grad_tol: default FRAME_GRAD_TOL for Newton, 0.01 for
    L-BFGS. Returns X
    (T, n, 2) pixels, energies (T,), iterations (T,) int64, all in time order.
    """
    if order not in ("forward", "backward"):
        raise ValueError(f"order must be 'forward' or 'backward', got {order!r}")
    d = deformer or Deformer(template.rest, template.faces, template.handles, mu=mu, method=FRAME_METHOD)
    if grad_tol is None:
        grad_tol = FRAME_GRAD_TOL if d.method == "newton" else 0.01
    T = len(poses)
    X = np.zeros((T, len(template.rest), 2))
    energies, iters = np.zeros(T), np.zeros(T, np.int64)
    frames = range(T) if order == "forward" else range(T - 1, -1, -1)
    x = None
    for i in frames:
        res = d.solve(template.handle_targets(poses[i]), x0=x, grad_tol=grad_tol)
        X[i], energies[i], iters[i], x = res.x, res.energy, res.iterations, res.x
    return X, energies, iters
