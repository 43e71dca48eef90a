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

The search (optimize_topology) takes the regions one at a time, the others
held at their current cuts, and its cost grows linearly with a region's
T-junctions: an even count has its 2 assignments; an odd count, whose cusp can
sit at any of the n - k other boundary vertices, is searched by stretch: the
cusp lies in one of the k stretches of boundary between consecutive
T-junctions, and either label can start at the first T-junction, so the 2k
(stretch, label) families are each probed once with the cusp in the middle
of its stretch, then the best family's cusp walks along its stretch in
halving steps (at most 2 log2 of its length more). Only a region's first
topology is deformed from rest along the motion; every other one starts from
the solution of its neighbour (the other cut of an even region, the family's
best cusp so far; else any topology of the region tried before, latest first:
on arm_cross's key1 with five more T-junctions the last probe carries over only
from the second, 0.066 -> 0.040 s; ops.geometry.warmstart), solved at the other pose: a
fraction of the iterations, unless the carried-over positions start above
WARM_START_LIMIT times the neighbour's energy (a cut moved across a limb
carries a crumpled start): then it too is deformed from rest along the motion,
which over the samples' 120 warm-startable topologies took 40 s where always
warm took 56 s and always from rest 84 s, the chosen cuts unchanged. Before
falling back to rest, the neighbour's solution at an earlier step of the
motion is tried, the latest that carries over fold-free and within the limit
(nearer the key's own pose the sheets have not parted yet), and the candidate
follows the motion from that step: over the samples' cut searches (22 keys,
and arm_cross's key1 with five more T-junctions) 4808 -> 4197 iterations,
13.8 -> 11.6 s, every chosen cut and energy unchanged (to 1e-7). Topologies are deformed by projected Newton
(Solver.method), which near a minimum takes 5-15x fewer iterations than the
lanes' L-BFGS and reaches the same energies there (ops.geometry.deform). (Before: optuna's TPE over all 2 (n - k) options,
up to 30 trials each deformed from rest, so turning an even region odd with
one more click multiplied its cost by up to 15.) A region whose boundary,
T-junctions, front bones, key poses and solver settings are those of a region
of a previous template (region_key) keeps that template's cut unsearched, and
when every region does and the incised mesh is that template's, the template
itself comes back, its solution at the other pose included (_previous_solution);
a region that runs out of its wall-clock budget keeps the best cut found.
"""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ops.geometry.deform import SEARCH_NEWTON_CAP, Deformer, count_flipped
from ops.geometry.implied_cut import implied_labels, switches_of
from ops.geometry.mesh import split_fans
from ops.geometry.polygon import project_to_polyline
from ops.geometry.template import TemplateBase, build_template
from ops.geometry.warmstart import transfer_positions
from ops.shotio.interpolate import interpolate_pose
from ops.types import RefinedMasks, Skeleton, Template, handle_targets, nest_group_list

PATH_STEPS = 4  # over the samples' topologies 2-4 steps reach the same energies; 4 takes the fewest iterations
WARM_START_LIMIT = 3.0  # a carried-over start above this multiple of its neighbour's energy: solved from rest
MAX_CUSP_MOVES = 8  # topologies an odd region's best cusp family may try along its stretch after the 2k probes
# two cuts whose energies differ by less than this fraction tie, and the one tried first is kept: over the test bed a
# third of the regions' two best cuts lay within 1e-4 of each other, where the last bits of the arithmetic (another
# CPU's kernels, any change to the geometry's code) chose either
TIE = 1e-4


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


def cusp_assignment(junctions: np.ndarray, cusp: int, first_label: int) -> Assignment:
    """Odd k: the assignment flipping at the T-junction indices (k,) and at `cusp`, the segment that starts at
    the first (lowest-index) T-junction labelled first_label."""
    jn = np.unique(np.asarray(junctions, dtype=np.int64))
    switches = np.sort(np.append(jn, int(cusp)))
    at = int(np.searchsorted(switches, jn[0]))  # 1 when the cusp comes before the first junction
    return alternating(switches, (first_label - at) % 2, int(cusp))


def cusp_stretches(n: int, junctions: np.ndarray) -> list[np.ndarray]:
    """Per stretch of a closed n-vertex boundary between consecutive T-junctions (k,) (the last wraps round to
    the first), its (a,) int64 vertex indices strictly between them, in order; stretches without one left out."""
    jn = np.unique(np.asarray(junctions, dtype=np.int64))
    ends = np.append(jn[1:], jn[0] + n)
    return [idx % n for idx in (np.arange(a + 1, b) for a, b in zip(jn, ends)) if len(idx)]


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
    upper: list[np.ndarray] = field(default_factory=list)  # per region (f_r,) int64 the faces its pocket copies,
    #                                                          in the order of its pocket's faces


def incise(base: TemplateBase, assignments: list[Assignment]) -> Incised:
    """Add each region's pocket and re-index vertices along its boundary per its assignment.

    Regions are taken front to back (base.stack). Each region's pocket copies the bottom-most copy so far of each
    of its faces (the front sheet's, or inside a region stacked above it that region's pocket), and its cut
    re-points the faces across its boundary at that level: the front sheet's, and the pockets of the regions it
    is nested with. Without nested regions this is the two-layer incision of §4.4."""
    V, F = base.V.copy(), base.F.copy()
    layer = np.zeros(len(F), np.int64)
    bottom = np.arange(len(F))  # per base face, its bottom-most copy so far
    origin = np.arange(len(V))  # per vertex, the base vertex it copies
    R = base.n_regions
    members, nested, through = base.region_faces, base.nested, base.handle_regions
    handles = base.handle_vertex.copy()
    warnings: list[str] = []
    switches: list[np.ndarray] = []
    upper: list[np.ndarray] = [np.zeros(0, np.int64)] * R
    for r in base.stack:
        a = assignments[r]
        cur = bottom[members[r]]
        in_r = np.zeros(len(F), bool)
        in_r[cur] = True
        # faces across the boundary: the front sheet's, and the pockets of the regions nested with this one
        level = (layer == 0) | np.isin(layer - 1, np.flatnonzero(nested[r]))
        outside = level & ~in_r
        rv = np.unique(F[cur])
        ends = base.boundary_vertex[r][a.switches]
        sw = rv[np.isin(origin[rv], ends)] if nested[r].any() else np.intersect1d(ends, rv)
        switches.append(sw)
        copy = np.setdiff1d(rv, sw)
        back = np.full(len(V), -1, np.int64)
        back[copy] = len(V) + np.arange(len(copy))
        back[sw] = sw
        V = np.concatenate([V, V[copy]])
        origin = np.concatenate([origin, origin[copy]])
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
        upper[r] = cur
        bottom[members[r]] = len(F) + np.arange(len(cur))
        F = np.concatenate([F, back[F[cur]]])
        layer = np.concatenate([layer, np.full(len(cur), r + 1, np.int64)])
        down = through[:, r]
        handles[down] = np.where(back[handles[down]] >= 0, back[handles[down]], handles[down])
    # a switch vertex where a slit from the T-junction meets the region's cut joins its sheets at one point
    if switches:
        F, split_origin = split_fans(F, len(V), np.concatenate(switches))
        V = V[split_origin]
    warnings += _nonmanifold_warning(F)
    return Incised(rest=V, faces=F, face_layer=layer, handles=handles, warnings=warnings, upper=upper)


def _nonmanifold_warning(F: np.ndarray) -> list[str]:
    """A warning if some edges have more than two faces (adjacent switch vertices sew three sheets)."""
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1).astype(np.int64)
    # one integer per edge: np.unique over rows (axis=0) sorts a structured view, ten times slower
    _, cnt = np.unique(e[:, 0] * (int(F.max(initial=0)) + 1) + e[:, 1], return_counts=True)
    bad = int((cnt > 2).sum())
    return [f"{bad} non-manifold edge(s) where switch vertices are adjacent"] if bad else []


@dataclass(frozen=True)
class Solver:
    """How a topology is deformed to be scored (ops.geometry.deform), and how long a region may be searched."""

    mu: float = 200.0
    grad_tol: float = 0.01
    max_iter: int = 5000
    region_budget_s: float | None = None  # wall-clock seconds per region's search; None: no limit
    method: str = "newton"  # Deformer's method (ops.geometry.deform.SOLVERS)
    newton_cap: float = SEARCH_NEWTON_CAP  # Newton's shortest step before L-BFGS's (ops.geometry.deform)


def pose_path(pose_self: np.ndarray, pose_other: np.ndarray, parents: np.ndarray, steps: int = PATH_STEPS) -> list:
    """(J, 3) poses at 1/steps, 2/steps, .., 1 of the way from pose_self to pose_other (per-bone angles, as the
    motion interpolates); the last is pose_other exactly."""
    return [interpolate_pose(pose_self, pose_other, i / steps, parents) for i in range(1, steps)] + [pose_other]


def handle_path(base: TemplateBase, pose_self: np.ndarray, pose_other: np.ndarray, parents: np.ndarray) -> list:
    """(h, 2) handle targets, pixels, of the template at each pose of pose_path: what a topology is scored on."""
    return [handle_targets(base.handle_weights, base.handle_offsets, base.handle_frames, pose)
            for pose in pose_path(pose_self, pose_other, parents)]


_SOLVE_ERRORS = (ValueError, RuntimeError, np.linalg.LinAlgError)  # a topology that cannot be deformed: energy inf


def prepare(base: TemplateBase, assignments: list[Assignment], solver: Solver = Solver()
            ) -> tuple[Incised, Deformer | None]:
    """The incised template of `assignments` and its Deformer (None when its energy cannot be set up)."""
    inc = incise(base, assignments)
    try:
        return inc, Deformer(inc.rest, inc.faces, inc.handles, solver.mu, solver.method,
                             newton_cap=solver.newton_cap)
    except _SOLVE_ERRORS:
        return inc, None


def evaluate(base: TemplateBase, assignments: list[Assignment], path: list[np.ndarray],
             solver: Solver = Solver(), x0: np.ndarray | None = None, x0_max_energy: float = np.inf,
             start: int | None = None, prepared: tuple[Incised, Deformer | None] | None = None
             ) -> tuple[float, Incised, list[tuple[np.ndarray, float] | None], bool]:
    """Energy (inf on failure) of deforming the incised template along handle targets path (each (h, 2)
    pixels), the incised template, per step of the path its vertices (n, 2) pixels and energy there (None
    where the solve did not start or failed), and whether the solve started from x0.

    From rest the deformation follows the whole path; from x0 ((n, 2) pixels, fold-free: a neighbouring
    topology's solution at step `start` of the path (default: the last), carried over, ops.geometry.warmstart)
    it follows the path from that step on, unless x0's energy there exceeds x0_max_energy: then from rest after
    all (module docstring). prepared: what `prepare` gave for these assignments (else made here)."""
    inc, d = prepared or prepare(base, assignments, solver)
    start = len(path) - 1 if start is None else start
    steps: list[tuple[np.ndarray, float] | None] = [None] * len(path)
    if d is None:
        return np.inf, inc, steps, False
    try:
        if x0 is not None and not d.energy(x0, path[start]) <= x0_max_energy:
            x0 = None
        if x0 is None:
            start = 0
        res = d.solve_along(path[start:], x0=x0, grad_tol=solver.grad_tol, max_iter=solver.max_iter)
        energy = res.energy if np.isfinite(res.energy) else np.inf
        if np.isfinite(energy):
            steps[start:] = list(zip(res.path_x, res.path_energy))
    except _SOLVE_ERRORS:
        energy = np.inf
    return float(energy), inc, steps, x0 is not None


def _key(assignments: list[Assignment]) -> tuple:
    """Hashable identity of a list of per-region assignments."""
    return tuple((tuple(a.switches.tolist()), tuple(a.labels.tolist())) for a in assignments)


@dataclass
class _Scored:
    """One evaluated topology (its energy summed over the target poses it is deformed to)."""

    energy: float
    inc: Incised
    assignments: list[Assignment]
    steps: list[list[tuple[np.ndarray, float] | None]]  # per target pose, per step of the path to it: (n, 2)
    #                                                     pixels and the energy there (None: not solved)
    energies: list[float]  # per target pose, the energy there
    warm: bool  # started from a neighbour's solution (else from rest, along the motion)


@dataclass
class _Search:
    """Memoized topology evaluation: every distinct combination of region cuts is solved once per target pose,
    warm-started from the first of the given neighbours whose solution carries over without a fold."""

    base: TemplateBase
    paths: list[list[np.ndarray]]  # per target pose, the (h, 2) handle targets towards it, pixels
    solver: Solver
    cache: dict[tuple, _Scored] = field(default_factory=dict)

    def score(self, assignments: list[Assignment], neighbours: list[tuple] = ()) -> _Scored:
        """The evaluated topology of `assignments` (one per region); neighbours: cache keys, in preference order."""
        key = _key(assignments)
        if key not in self.cache:
            es, xs, warm = [], [], True
            prepared = prepare(self.base, assignments, self.solver)  # once for every target pose and start
            inc = prepared[0]
            for i, path in enumerate(self.paths):
                x0, limit, start = self._warm_start(assignments, neighbours, i, prepared)
                e, _, x, warmed = evaluate(self.base, assignments, path, self.solver, x0, limit, start, prepared)
                if warmed and not np.isfinite(e):  # the warm start failed: from rest after all
                    e, _, x, warmed = evaluate(self.base, assignments, path, self.solver, prepared=prepared)
                es, warm = es + [e], warm and warmed
                xs.append(x)
            self.cache[key] = _Scored(float(sum(es)), inc, list(assignments), xs, es, warm)
        return self.cache[key]

    def _warm_start(self, assignments: list[Assignment], neighbours, i: int,
                    prepared: tuple[Incised, Deformer | None] | None = None
                    ) -> tuple[np.ndarray | None, float, int | None]:
        """A fold-free start (n, 2) pixels on the path to target i carried over from a neighbour (else None), the
        most energy it may start with (WARM_START_LIMIT times the neighbour's there), and its step of the path:
        the latest step any neighbour's solution carries over to without a fold, neighbours in preference order
        within a step. Near the key's own pose the sheets have not parted yet, so a cut that moved across a limb
        carries over at an earlier step where at the last it folds or starts crumpled.

        A region whose cut is the neighbour's with every label flipped (the other cut of an even count, the
        other family of an odd one at the same cusp) sews its pocket where the neighbour sewed its front: its
        front faces take the neighbour's pocket faces' corners and its pocket faces the front ones', so every
        face keeps an unfolded shape (carried corner by corner, about half of them fold). prepared: `prepare`'s
        for `assignments` (else made here)."""
        sources = [self.cache[k] for k in neighbours if k in self.cache]
        inc, d = prepared or prepare(self.base, assignments, self.solver)
        if not sources or d is None:
            return None, np.inf, None
        faces = [self._source_faces(assignments, src) for src in sources]
        for step in range(len(self.paths[i]) - 1, -1, -1):
            for src, source_faces in zip(sources, faces):
                if src.steps[i][step] is None:
                    continue
                x, energy = src.steps[i][step]
                x0 = transfer_positions(x, source_faces, inc.faces, inc.rest)
                if count_flipped(x0, inc.faces) > 0:
                    continue
                if d.energy(x0, self.paths[i][step]) <= WARM_START_LIMIT * energy:
                    return x0, WARM_START_LIMIT * energy, step
        return None, np.inf, None

    def _source_faces(self, assignments: list[Assignment], src: _Scored) -> np.ndarray:
        """src's faces (m, 3), with the front and pocket faces of every region whose labels `assignments` flips
        swapped (the corners the transfer carries over face by face)."""
        source_faces = src.inc.faces.copy()
        for r, (mine, theirs) in enumerate(zip(assignments, src.assignments)):
            if np.array_equal(mine.switches, theirs.switches) and np.array_equal(mine.labels, 1 - theirs.labels):
                front = src.inc.upper[r]
                pocket = np.flatnonzero(src.inc.face_layer == r + 1)
                source_faces[front], source_faces[pocket] = src.inc.faces[pocket], src.inc.faces[front]
        return source_faces


@dataclass
class _Region:
    """One region's search: its options and the deadline of its budget."""

    search: _Search
    choice: list[Assignment]  # the current cut of every region
    r: int
    deadline: float  # time.monotonic() after which no further topology is evaluated
    evaluated: int = 0
    out_of_budget: bool = False
    tried: list[tuple] = field(default_factory=list)  # keys of the topologies scored for this region, in order

    def energy(self, a: Assignment, neighbours: list[Assignment] = ()) -> float:
        """Energy with region r cut by `a` (warm-started from the topologies with region r cut by `neighbours`);
        inf without evaluating once the budget is spent (the first topology is always evaluated)."""
        trial = self.choice[:self.r] + [a] + self.choice[self.r + 1:]
        key = _key(trial)
        if key not in self.search.cache:
            if self.evaluated and time.monotonic() > self.deadline:
                self.out_of_budget = True
                return np.inf
            self.evaluated += 1
        near = [_key(self.choice[:self.r] + [b] + self.choice[self.r + 1:]) for b in neighbours]
        near += self.tried[::-1]  # else the region's other topologies, latest first
        scored = self.search.score(trial, near)
        if key not in self.tried:
            self.tried.append(key)
        return scored.energy


def lower(energy: float, than: float) -> bool:
    """Whether a cut of this energy beats one of energy `than` by more than a tie (TIE; any finite one beats inf)."""
    return energy < than - TIE * abs(than) if np.isfinite(than) else energy < than


def _first_best(scored: dict) -> object:
    """The key of the lowest energy in `scored` (in the order tried), a later one taking over only when lower
    beyond a tie."""
    keys = iter(scored)
    best = next(keys)
    for k in keys:
        if lower(scored[k], scored[best]):
            best = k
    return best


def _search_even(region: _Region, junctions: np.ndarray) -> Assignment:
    """Better of the two assignments of an even count (the first on a tie); the second warm-started from the
    first."""
    a, b = alternating(junctions, 0), alternating(junctions, 1)
    ea = region.energy(a)
    eb = region.energy(b, [a])
    return b if lower(eb, ea) else a


def _search_implied(region: _Region, implied: Assignment) -> Assignment:
    """A region without T-junctions: the better of its two uniform cuts and the cut its outline implies
    (ops.geometry.implied_cut; the earlier on a tie), the last warm-started from the better of the first two."""
    a, b = alternating(np.zeros(0, np.int64), 0), alternating(np.zeros(0, np.int64), 1)
    scored = {0: region.energy(a), 1: region.energy(b, [a])}
    first = _first_best(scored)
    best = (a, b)[first]
    e = region.energy(implied, [best, b if best is a else a])
    return implied if lower(e, scored[first]) else best


def _search_odd(region: _Region, n: int, junctions: np.ndarray) -> Assignment:
    """Best cusp assignment found: each (stretch, first label) family probed with the cusp mid-stretch, then the
    best family's cusp moved along its stretch in halving steps while that lowers the energy beyond a tie (the
    family and the cusp tried first win a tie)."""
    stretches = cusp_stretches(n, junctions)
    refinements = 0
    scored: dict[tuple, float] = {}  # (first label, stretch, position in it) -> energy
    last: dict[int, Assignment] = {}  # per first label, the previous probe: the next one's warm start

    def probe(label: int, s: int, i: int, near: list[Assignment]) -> float:
        a = cusp_assignment(junctions, int(stretches[s][i]), label)
        scored[(label, s, i)] = region.energy(a, near)
        return scored[(label, s, i)]

    for s, idx in enumerate(stretches):  # label 0 from the previous stretch's probe, label 1 from label 0's
        for label in (0, 1):
            near = [cusp_assignment(junctions, int(idx[len(idx) // 2]), 0)] if label else []
            near += [last[label]] if label in last else []
            probe(label, s, len(idx) // 2, near)
            last[label] = cusp_assignment(junctions, int(idx[len(idx) // 2]), label)
    label, s, i = _first_best(scored)
    best = scored[(label, s, i)]
    step = max(len(stretches[s]) // 4, 1)
    while step >= 1 and refinements < MAX_CUSP_MOVES:
        here = cusp_assignment(junctions, int(stretches[s][i]), label)
        moves = [j for j in (i - step, i + step) if 0 <= j < len(stretches[s]) and (label, s, j) not in scored]
        for j in moves[:MAX_CUSP_MOVES - refinements]:
            probe(label, s, j, [here])
            refinements += 1
        j = min((j for j in (i - step, i + step) if (label, s, j) in scored), key=lambda j: scored[(label, s, j)],
                default=i)
        if lower(scored.get((label, s, j), np.inf), best):
            i, best = j, scored[(label, s, j)]
        else:
            step //= 2
    return cusp_assignment(junctions, int(stretches[s][i]), label)


def region_key(refined: RefinedMasks, r: int, pose_self: np.ndarray, targets: list[np.ndarray], mode: str,
               solver: Solver, implied_cuts: bool = True) -> str:
    """Digest (24 hex) of what region r's cut search reads: its boundary polyline (pixels, to 1e-6), its
    T-junction indices and front bones, the key's pose and every target pose, the template mode, the solver's
    settings, for a region without T-junctions whether its implied cut is tried and its mask (which the
    implied cut reads), and for a region of a nest group (three local layers) the boundaries and front bones of
    the group's other regions, which decide the level its pocket is made at."""
    h = hashlib.sha256()
    junctions = np.unique(np.asarray(refined.junctions[r], np.int64))
    implied = implied_cuts and len(junctions) == 0
    groups = nest_group_list(refined.nest_groups, len(refined.boundaries))
    partners = [q for q in range(len(groups)) if q != r and groups[r] >= 0 and groups[q] == groups[r]]
    for a in (np.round(np.asarray(refined.boundaries[r], np.float64), 6), junctions,
              np.asarray(refined.front_bones[r], np.int64), np.asarray(pose_self, np.float64),
              *(np.asarray(t, np.float64) for t in targets),
              *((np.packbits(refined.occlusion[r]), np.packbits(refined.foreground)) if implied else ()),
              *(part for q in partners for part in (np.round(np.asarray(refined.boundaries[q], np.float64), 6),
                                                      np.asarray(refined.front_bones[q], np.int64)))):
        h.update(str(a.shape).encode())
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(repr((mode, solver.mu, solver.grad_tol, solver.max_iter, solver.method, PATH_STEPS, solver.newton_cap)
                  + (("implied",) if implied else ())).encode())
    return h.hexdigest()[:24]


def implied_cut(base: TemplateBase, refined: RefinedMasks, r: int, pose: np.ndarray, skeleton: Skeleton
                ) -> Assignment | None:
    """Region r's cut as its outline implies it (ops.geometry.implied_cut), or None where that is uniform (one
    of the two cuts a region without T-junctions has anyway)."""
    labels = implied_labels(base.boundaries[r], refined.occlusion[r], refined.foreground, refined.front_bones[r],
                            pose, skeleton)
    switches, segment_labels_ = switches_of(labels)
    return Assignment(switches=switches, labels=segment_labels_) if len(switches) else None


def _first_option(n: int, junctions: np.ndarray) -> Assignment:
    """The cut a region starts from before its own search: label 0 from the first T-junction (cusp mid-stretch)."""
    if len(junctions) % 2 == 0:
        return alternating(junctions, 0)
    idx = cusp_stretches(n, junctions)[0]
    return cusp_assignment(junctions, int(idx[len(idx) // 2]), 0)


def _previous_cut(previous: Template | None, key: str, n: int) -> Assignment | None:
    """Region `key`'s cut in the previous template (n boundary vertices), or None if it has no such region."""
    if previous is None or key not in previous.region_keys:
        return None
    i = previous.region_keys.index(key)
    switches = np.asarray(previous.cut_switches[i], np.int64)
    labels = np.asarray(previous.cut_assignment[i], np.int8)
    if len(labels) != max(len(switches), 1) or (len(switches) and (switches.min() < 0 or switches.max() >= n)):
        return None  # not a record this search wrote
    return Assignment(switches=switches, labels=labels)


def optimize_topology(
    refined: RefinedMasks,
    pose_self: np.ndarray,
    pose_other: np.ndarray | list[np.ndarray],
    skeleton: Skeleton,
    mode: str = "optimized",
    max_area: float | None = None,
    solver: Solver = Solver(),
    previous: Template | None = None,
    implied_cuts: bool = True,
) -> Template:
    """Build the template at pose_self (J, 3) and pick per region the cut minimizing the energy at pose_other (J, 3),
    or summed over a list of target poses (the neighbouring keys' poses: the key deforms well on both sides).

    previous: the template an earlier run built for this keyframe; its regions' cuts are kept, unsearched,
    for the regions whose region_key it records (Template.reused_regions). implied_cuts: a region without
    T-junctions also tries the cut its outline implies (ops.geometry.implied_cut), besides its two uniform ones."""
    base = build_template(refined, pose_self, skeleton, mode, max_area)
    targets = [pose_other] if np.ndim(pose_other) == 2 else list(pose_other)
    search = _Search(base, [handle_path(base, pose_self, t, skeleton.parents) for t in targets], solver)
    keys = [region_key(refined, r, pose_self, targets, mode, solver, implied_cuts) for r in range(base.n_regions)]
    choice, reused = [], []
    for r in range(base.n_regions):
        n, jn = len(base.boundaries[r]), base.junctions[r]
        kept = _previous_cut(previous, keys[r], n) if np.array_equal(jn, np.unique(refined.junctions[r])) else None
        if kept is not None:
            reused.append(r)
        choice.append(kept if kept is not None else _first_option(n, jn))
    over = []
    for r in range(base.n_regions):
        if r in reused:
            continue
        budget = solver.region_budget_s
        region = _Region(search, choice, r, time.monotonic() + (budget if budget is not None else np.inf))
        n, jn = len(base.boundaries[r]), base.junctions[r]
        implied = implied_cut(base, refined, r, pose_self, skeleton) if implied_cuts and len(jn) == 0 else None
        if implied is not None:
            choice[r] = _search_implied(region, implied)
        else:
            choice[r] = _search_even(region, jn) if len(jn) % 2 == 0 else _search_odd(region, n, jn)
        if region.out_of_budget:
            over.append(r)
    kept_cuts = (f"kept the cuts of {len(reused)} unchanged occlusion region(s) {reused} from the previous "
                 "template, without searching")
    # only the region keys vouch for the poses and the solver's settings: a template without a region is solved
    all_kept = 0 < len(reused) == base.n_regions
    unchanged = _previous_solution(previous, base, choice, keys, len(targets), kept_cuts) if all_kept else None
    if unchanged is not None:
        return unchanged
    winner = search.score(choice, list(search.cache)[-1:])
    warnings = base.warnings + winner.inc.warnings
    if reused:
        warnings.append(kept_cuts)
    if over:
        warnings.append(f"the cut search of occlusion region(s) {over} ran out of its {solver.region_budget_s:g} s "
                        "budget: kept the best cut found by then (raise Settings.topology_budget for a full search)")
    if not np.isfinite(winner.energy):
        warnings.append("no topology deformed to the other keyframe's pose without failure")
    return Template(
        rest=winner.inc.rest, faces=winner.inc.faces, face_layer=winner.inc.face_layer, handles=winner.inc.handles,
        handle_weights=base.handle_weights, handle_offsets=base.handle_offsets, handle_frames=base.handle_frames,
        cut_assignment=[a.labels.copy() for a in choice], energy=float(winner.energy), trials=len(search.cache),
        mode=mode, warnings=warnings, cut_switches=[a.switches.copy() for a in choice], region_keys=keys,
        reused_regions=reused, budget_regions=over, target_x=[_last_solution(path) for path in winner.steps],
    )


def _previous_solution(previous: Template | None, base: TemplateBase, choice: list[Assignment], keys: list[str],
                       n_targets: int, warning: str) -> Template | None:
    """The previous template itself, its solution at the target poses and energy included, when every region kept
    its cut and the incised mesh and its handles are the previous one's, vertex for vertex; else None.

    Solving again from rest would land elsewhere in a flat valley of the same energy (3 px on a realdev shot), and
    the lane's texturing and registration downstream turn that into visibly different frames: an unchanged
    template (a rerun after an upgrade, or after a change to a setting the cuts do not read, such as the search's
    budget) now comes back exactly. warning: the one that says the cuts were kept."""
    if previous is None or len(previous.target_x) != n_targets:
        return None
    inc = incise(base, choice)
    same = [(inc.rest, previous.rest), (inc.faces, previous.faces), (inc.face_layer, previous.face_layer),
            (inc.handles, previous.handles), (base.handle_weights, previous.handle_weights),
            (base.handle_offsets, previous.handle_offsets), (base.handle_frames, previous.handle_frames)]
    if not all(np.shape(a) == np.shape(b) and np.array_equal(a, b) for a, b in same):
        return None
    if any(len(x) and np.shape(x) != inc.rest.shape for x in previous.target_x):
        return None
    return replace(previous, trials=0, region_keys=list(keys), reused_regions=list(range(base.n_regions)),
                   budget_regions=[], warnings=base.warnings + inc.warnings + [
                       f"{warning}, and its solution at the other key's pose, without solving"])


def _last_solution(steps: list[tuple[np.ndarray, float] | None]) -> np.ndarray:
    """(n, 2) pixels: the solution at a path's last step (its target pose), or (0, 2) where none was found."""
    last = steps[-1] if steps else None
    return np.array(last[0], np.float64) if last is not None and np.isfinite(last[1]) else np.zeros((0, 2))
