"""Cut topology of the 2.5D template: switching rule, incision and its optimization (§4.4).

Each occlusion region's boundary polyline (n vertices, k T-junctions) is split
into segments at *switch* vertices (the T-junctions, plus one cusp when k is
odd). Label 0: the region's front is sewn to the outside there; label 1: its
pocket is sewn to the outside and the front is cut free. Labels alternate at
every switch, so an even k allows exactly 2 assignments and an odd k, which
needs one extra switch (a cusp) at one of the n - k other vertices, 2 (n - k).

Incision is pure vertex re-indexing: every vertex of region r gets a back copy
used by the pocket faces (switch vertices keep one shared vertex); outside
faces at a boundary vertex of a 1-segment are re-pointed to the back copy.
A topology is scored by deforming the template from its rest pose to the
other keyframe's pose (ops.deform); the lowest energy wins. The deformation
follows the motion between the two key poses in PATH_STEPS steps
(Deformer.solve_along): it reaches the minimum the lane's frame-by-frame
deformation reaches, where a direct solve often stopped in a crumpled one,
so each topology is scored by the deformation the lane will actually show.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import optuna

from ops.geometry.deform import Deformer
from ops.geometry.mesh import split_fans
from ops.geometry.polygon import project_to_polyline
from ops.geometry.template import TemplateBase, build_template
from ops.shotio.interpolate import interpolate_pose
from ops.types import RefinedMasks, Skeleton, Template, handle_targets

MAX_ODD_TRIALS = 30
PATH_STEPS = 4  # over the samples' topologies 2-4 steps reach the same energies; 4 takes the fewest iterations
_FAILED = 1e12  # stands in for +inf energy inside optuna


@dataclass(frozen=True)
class Assignment:
    """One region's cut: switch vertices and the label of each segment between them."""

    switches: np.ndarray  # (s,) int64 sorted boundary-polyline indices where the label flips
    labels: np.ndarray  # (max(s, 1),) int8 label of segment i = [switches[i], switches[i+1]) (cyclic)
    cusp: int = -1  # polyline index of the added cusp (odd k), -1 if none


def count_assignments(n: int, k: int) -> int:
    """Number of valid assignments of a boundary with n vertices and k T-junctions: 2 (even k) or 2 (n - k)."""
    return 2 if k % 2 == 0 else 2 * (n - k)


def alternating(switches: np.ndarray, start: int, cusp: int = -1) -> Assignment:
    """Assignment flipping at every switch (s even, or 0), first segment labelled `start`."""
    sw = np.sort(np.asarray(switches, dtype=np.int64))
    if len(sw) % 2:
        raise ValueError(f"labels can only alternate around a loop at an even number of switches, got {len(sw)}")
    labels = ((start + np.arange(max(len(sw), 1))) % 2).astype(np.int8)
    return Assignment(switches=sw, labels=labels, cusp=cusp)


def odd_assignment(n: int, junctions: np.ndarray, index: int) -> Assignment:
    """The index-th of the 2 (n - k) odd-k assignments: cusp = index // 2-th non-junction vertex, start = index % 2."""
    jn = np.unique(np.asarray(junctions, dtype=np.int64))
    others = np.setdiff1d(np.arange(n), jn)
    cusp = int(others[index // 2])
    return alternating(np.append(jn, cusp), index % 2, cusp)


def enumerate_assignments(n: int, junctions: np.ndarray) -> list[Assignment]:
    """All valid assignments of a boundary of n vertices with T-junction indices (k,): 2 or 2 (n - k)."""
    jn = np.unique(np.asarray(junctions, dtype=np.int64))
    if len(jn) % 2 == 0:
        return [alternating(jn, 0), alternating(jn, 1)]
    return [odd_assignment(n, jn, i) for i in range(count_assignments(n, len(jn)))]


def segment_labels(a: Assignment, param: np.ndarray) -> np.ndarray:
    """(q,) int8 label at polyline parameters param (q,) in [0, n) (i + s = fraction s along edge i)."""
    if len(a.switches) == 0:
        return np.full(len(param), a.labels[0], np.int8)
    seg = np.searchsorted(a.switches, param, side="right") - 1  # -1: wraps into the last segment
    return a.labels[seg % len(a.switches)]


@dataclass
class Incised:
    """A template mesh with pockets sewn per an assignment."""

    rest: np.ndarray  # (n, 2) float64 pixels
    faces: np.ndarray  # (m, 3) int64
    face_layer: np.ndarray  # (m,) int64
    handles: np.ndarray  # (h,) int64
    warnings: list[str]


def incise(base: TemplateBase, assignments: list[Assignment]) -> Incised:
    """Add each region's pocket and re-index vertices along its boundary per its assignment."""
    V, F = base.V.copy(), base.F.copy()
    layer = np.zeros(len(F), np.int64)
    region = base.face_region.copy()
    handles = base.handle_vertex.copy()
    warnings: list[str] = []
    switches: list[np.ndarray] = []
    for r, a in enumerate(assignments):
        in_r = region == r
        outside = (layer == 0) & ~in_r
        rv = np.unique(F[in_r])
        sw = np.intersect1d(base.boundary_vertex[r][a.switches], rv)
        switches.append(sw)
        copy = np.setdiff1d(rv, sw)
        back = np.full(len(V), -1, np.int64)
        back[copy] = len(V) + np.arange(len(copy))
        back[sw] = sw
        V = np.concatenate([V, V[copy]])
        back = np.concatenate([back, np.full(len(copy), -1, np.int64)])
        # Boundary vertices: region vertices that outside faces also use (outer-boundary ones are not).
        used_out = np.zeros(len(V), bool)
        used_out[F[outside].ravel()] = True
        cut = copy[used_out[copy]]
        param, _ = project_to_polyline(V[cut], base.boundaries[r])
        remap = np.arange(len(V))
        moved = cut[segment_labels(a, param) == 1]
        remap[moved] = back[moved]
        F[outside] = remap[F[outside]]
        F = np.concatenate([F, back[F[in_r]]])
        layer = np.concatenate([layer, np.full(int(in_r.sum()), r + 1, np.int64)])
        region = np.concatenate([region, np.full(int(in_r.sum()), -1, np.int64)])
        on_pocket = base.handle_layer == r + 1
        handles[on_pocket] = np.where(back[handles[on_pocket]] >= 0, back[handles[on_pocket]], handles[on_pocket])
    # a switch vertex where a slit from the T-junction meets the region's cut joins its sheets at one point
    if switches:
        F, origin = split_fans(F, len(V), np.concatenate(switches))
        V = V[origin]
    warnings += _nonmanifold_warning(F)
    return Incised(rest=V, faces=F, face_layer=layer, handles=handles, warnings=warnings)


def _nonmanifold_warning(F: np.ndarray) -> list[str]:
    """A warning if some edges have more than two faces (adjacent switch vertices sew three sheets)."""
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, cnt = np.unique(e, axis=0, return_counts=True)
    bad = int((cnt > 2).sum())
    return [f"{bad} non-manifold edge(s) where switch vertices are adjacent"] if bad else []


@dataclass(frozen=True)
class Solver:
    """How a topology is deformed to be scored (ops.geometry.deform)."""

    mu: float = 200.0
    grad_tol: float = 0.01
    max_iter: int = 5000


def pose_path(pose_self: np.ndarray, pose_other: np.ndarray, parents: np.ndarray, steps: int = PATH_STEPS) -> list:
    """(J, 3) poses at 1/steps, 2/steps, .., 1 of the way from pose_self to pose_other (per-bone angles, as the
    motion interpolates); the last is pose_other exactly."""
    return [interpolate_pose(pose_self, pose_other, i / steps, parents) for i in range(1, steps)] + [pose_other]


def handle_path(base: TemplateBase, pose_self: np.ndarray, pose_other: np.ndarray, parents: np.ndarray) -> list:
    """(h, 2) handle targets, pixels, of the template at each pose of pose_path: what a topology is scored on."""
    return [handle_targets(base.handle_weights, base.handle_offsets, base.handle_frames, pose)
            for pose in pose_path(pose_self, pose_other, parents)]


def evaluate(base: TemplateBase, assignments: list[Assignment], path: list[np.ndarray],
             solver: Solver = Solver()) -> tuple[float, Incised, np.ndarray | None]:
    """Energy (inf on failure) of deforming the incised template from rest along handle targets path (each
    (h, 2) pixels), the incised template, and its vertices (n, 2) pixels at the last targets (None on failure)."""
    inc = incise(base, assignments)
    try:
        res = Deformer(inc.rest, inc.faces, inc.handles, solver.mu).solve_along(
            path, grad_tol=solver.grad_tol, max_iter=solver.max_iter)
        energy, x = (res.energy, res.x) if np.isfinite(res.energy) else (np.inf, None)
    except (ValueError, RuntimeError, np.linalg.LinAlgError):
        energy, x = np.inf, None
    return float(energy), inc, x


class _Search:
    """Memoized topology evaluation: every distinct combination of region choices is solved once."""

    def __init__(self, base: TemplateBase, paths: list[list[np.ndarray]], solver: Solver):
        """base: the front-sheet template; paths: per target pose, the (h, 2) handle targets towards it, pixels."""
        self.base, self.paths, self.solver = base, paths, solver
        self.cache: dict[tuple, tuple[float, Incised, list[Assignment]]] = {}

    def score(self, choice: tuple, options: list) -> float:
        """Energy of the per-region option indices `choice` (options[r](i) -> Assignment)."""
        if choice not in self.cache:
            assign = [options[r](i) for r, i in enumerate(choice)]
            scored = [evaluate(self.base, assign, path, self.solver) for path in self.paths]
            self.cache[choice] = (float(sum(e for e, _, _ in scored)), scored[0][1], assign)
        return self.cache[choice][0]


def _region_optimum(search: _Search, choice: list[int], r: int, options: list, n_opt: int, k: int, seed: int) -> int:
    """Best option index for region r with the other regions fixed: exhaustive (even k) or TPE (odd k)."""
    def energy(i: int) -> float:
        """Energy with region r set to option i."""
        return search.score(tuple(choice[:r] + [i] + choice[r + 1:]), options)

    if k % 2 == 0:
        scores = [energy(i) for i in range(n_opt)]
        return int(np.argmin(scores))
    optuna.logging.set_verbosity(logging.WARNING)
    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=seed + r))

    def objective(trial: optuna.Trial) -> float:
        """Optuna objective: energy of the suggested (cusp, starting side) option, finite."""
        e = energy(trial.suggest_categorical("option", list(range(n_opt))))
        return e if np.isfinite(e) else _FAILED

    study.optimize(objective, n_trials=min(n_opt, MAX_ODD_TRIALS))
    return int(study.best_params["option"])


def optimize_topology(
    refined: RefinedMasks,
    pose_self: np.ndarray,
    pose_other: np.ndarray | list[np.ndarray],
    skeleton: Skeleton,
    mode: str = "optimized",
    seed: int = 0,
    max_area: float | None = None,
    solver: Solver = Solver(),
) -> Template:
    """Build the template at pose_self (J, 3) and pick per region the cut minimizing the energy at pose_other (J, 3),
    or summed over a list of target poses (the neighbouring keys' poses: the key deforms well on both sides)."""
    base = build_template(refined, pose_self, skeleton, mode, max_area)
    targets = [pose_other] if isinstance(pose_other, np.ndarray) and pose_other.ndim == 2 else list(pose_other)
    search = _Search(base, [handle_path(base, pose_self, t, skeleton.parents) for t in targets], solver)
    options, sizes, ks = [], [], []
    for r in range(base.n_regions):
        n, jn = len(base.boundaries[r]), base.junctions[r]
        ks.append(len(jn))
        sizes.append(count_assignments(n, len(jn)))
        options.append(_option_fn(n, jn))
    choice = [0] * base.n_regions
    for r in range(base.n_regions):
        choice[r] = _region_optimum(search, choice, r, options, sizes[r], ks[r], seed)
    energy = search.score(tuple(choice), options)
    _, inc, assign = search.cache[tuple(choice)]
    warnings = base.warnings + inc.warnings
    if not np.isfinite(energy):
        warnings.append("no topology deformed to the other keyframe's pose without failure")
    return Template(
        rest=inc.rest, faces=inc.faces, face_layer=inc.face_layer, handles=inc.handles,
        handle_weights=base.handle_weights, handle_offsets=base.handle_offsets, handle_frames=base.handle_frames,
        cut_assignment=[a.labels.copy() for a in assign],
        energy=float(energy), trials=len(search.cache), mode=mode, warnings=warnings,
    )


def _option_fn(n: int, junctions: np.ndarray):
    """Option index -> Assignment for one region (2 options for even k, 2 (n - k) for odd k)."""
    if len(junctions) % 2 == 0:
        return lambda i: alternating(junctions, i)
    return lambda i: odd_assignment(n, junctions, i)
