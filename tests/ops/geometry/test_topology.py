"""Tests of ops.topology: switching-rule counts, incision by re-indexing, seeded search."""
import itertools
import types

import cv2
import numpy as np
import pytest

from ops.appearance.inpaint import make_inpainter
from ops.appearance.lane import texture_lane
from ops.geometry.deform import Deformer, count_flipped, deform_sequence
from ops.geometry.mesh import boundary_loops, vertex_components
from ops.geometry.polygon import project_to_polyline
from ops.geometry.template import build_template
from ops.geometry.topology import (
    MAX_CUSP_MOVES,
    TIE,
    WARM_START_LIMIT,
    Assignment,
    Solver,
    _key,
    _Region,
    _Search,
    _search_even,
    _search_odd,
    alternating,
    count_assignments,
    cusp_assignment,
    cusp_stretches,
    enumerate_assignments,
    evaluate,
    handle_path,
    incise,
    lower,
    odd_assignment,
    optimize_topology,
    pose_path,
    segment_labels,
)
from ops.geometry.warmstart import transfer_positions
from ops.types import RefinedMasks, Skeleton, Template
from tests.ops.geometry.test_template import capsule, capsule_scene


def edge_labels(a, n):
    """Label of each polyline edge i -> i+1 under assignment a."""
    return tuple(segment_labels(a, np.arange(n) + 0.5).tolist())


def brute_force(n, junctions):
    """All edge labelings whose label changes exactly at the junctions (+ one cusp when k is odd)."""
    jn, k = set(junctions), len(junctions)
    out = set()
    for lab in itertools.product((0, 1), repeat=n):
        flips = {i for i in range(n) if lab[i - 1] != lab[i]}
        if flips == jn or (k % 2 == 1 and jn < flips and len(flips) == k + 1):
            out.add(lab)
    return out


@pytest.mark.parametrize("n,junctions", [(8, []), (8, [2, 5]), (9, [0, 3, 4, 7]), (8, [3]), (9, [1, 4, 6]), (7, [0, 1, 2, 3, 4])])
def test_assignment_counts_match_switching_rule(n, junctions):
    opts = enumerate_assignments(n, np.array(junctions))
    k = len(junctions)
    assert len(opts) == count_assignments(n, k) == (2 if k % 2 == 0 else 2 * (n - k))
    labs = {edge_labels(a, n) for a in opts}
    assert len(labs) == len(opts)  # all distinct
    assert labs == brute_force(n, junctions)
    for a in opts:
        assert len(a.switches) % 2 == 0
        if k % 2:
            assert a.cusp >= 0 and a.cusp not in junctions


def test_odd_assignment_indexing_and_errors():
    a = odd_assignment(10, np.array([4]), 5)  # cusp = third non-junction vertex (2), start = 1
    assert a.cusp == 2 and a.switches.tolist() == [2, 4] and a.labels.tolist() == [1, 0]
    with pytest.raises(ValueError):
        alternating(np.array([1, 2, 3]), 0)


def square_scene(junctions, slits=()):
    """60 px square foreground with a 20 px square occlusion region (8 boundary vertices) in the middle."""
    def sq(x0, s, n_side):
        t = np.linspace(0, 1, n_side, endpoint=False)[:, None]
        c = np.array([[x0, x0], [x0 + s, x0], [x0 + s, x0 + s], [x0, x0 + s]], float)
        return np.concatenate([c[i] + t * (c[(i + 1) % 4] - c[i]) for i in range(4)])

    sk = Skeleton(joints=("a", "b"), parents=np.array([-1, 0]))
    pose = np.array([[10.0, 10.0, 0.0], [50.0, 50.0, 0.0]])
    refined = RefinedMasks(
        foreground=np.ones((61, 61), bool), occlusion=[np.zeros((61, 61), bool)], front_bones=[np.zeros(0, np.int64)],
        boundaries=[sq(20.0, 20.0, 2)], junctions=[np.array(junctions, np.int64)], domain=[sq(0.0, 60.0, 3)], domain_holes=np.zeros((0, 2)),
        coverage=np.ones((61, 61), np.float32), paper=np.ones((61, 61, 3), np.float32), colour=np.ones((61, 61, 3), np.float32),
        slits=[np.asarray(s, np.float64) for s in slits],
    )
    return build_template(refined, pose, sk, max_area=8.0), refined, sk, pose


def region_boundary(base):
    """Front-sheet vertices lying on the region polygon (the region's boundary cycle)."""
    rv = np.unique(base.F[base.face_region == 0])
    _, d = project_to_polyline(base.V[rv], base.boundaries[0])
    return rv[d < 1e-9]


@pytest.mark.parametrize("start", [0, 1])
def test_incision_two_junctions(start, midpoint_handles):
    base, *_ = square_scene([0, 4])
    n0, m0 = len(base.V), len(base.F)
    rv = np.unique(base.F[base.face_region == 0])
    ring = region_boundary(base)
    a = alternating(base.junctions[0], start)
    inc = incise(base, [a])
    assert len(inc.rest) == n0 + len(rv) - 2  # every region vertex copied except the 2 switch vertices
    assert np.bincount(inc.face_layer).tolist() == [m0, int((base.face_region == 0).sum())]
    assert count_flipped(inc.rest, inc.faces) == 0
    assert len(np.unique(vertex_components(len(inc.rest), inc.faces))) == 1  # sewn at the switches
    loops = boundary_loops(inc.faces)
    assert len(loops) == 2
    assert sorted(len(l) for l in loops) == sorted([len(boundary_loops(base.F)[0]), len(ring)])
    # One loop runs along the region boundary: front copies on 1-segments, back copies on 0-segments.
    on_region = [project_to_polyline(inc.rest[l], base.boundaries[0])[1].max() < 1e-9 for l in loops]
    assert sorted(on_region) == [False, True]
    cut = loops[int(np.argmax(on_region))]
    assert len(cut) == len(ring)
    param, _ = project_to_polyline(inc.rest[cut], base.boundaries[0])
    sw = np.isin(cut, base.boundary_vertex[0][base.junctions[0]])
    lab = segment_labels(a, param)
    assert sw.sum() == 2
    assert ((cut[~sw] < n0) == (lab[~sw] == 1)).all()
    # The pocket handle (midpoint of a back bone, at the square's centre) is a back copy.
    assert inc.handles[2] >= n0 and np.allclose(inc.rest[inc.handles[2]], [30.0, 30.0])


@pytest.mark.parametrize("start", [0, 1])
def test_slits_from_the_junctions_part_front_and_pocket(start, midpoint_handles):
    """Slits from both T-junctions (square corners (20, 20) and (40, 40)) out to the outline's corners divide the
    outside in two halves: one sewn to the region's front, the other to its pocket. Where a slit meets the
    region's cut at a switch vertex the sheets touch at that one point; they must come apart there, not hinge."""
    base, *_ = square_scene([0, 4], slits=[[[20.0, 20.0], [0.0, 0.0]], [[40.0, 40.0], [60.0, 60.0]]])
    sw = base.boundary_vertex[0][base.junctions[0]]
    assert np.allclose(np.sort(base.V[sw], axis=0), [[20.0, 20.0], [40.0, 40.0]])
    inc = incise(base, [alternating(base.junctions[0], start)])
    comp = vertex_components(len(inc.rest), inc.faces)
    assert len(np.unique(comp)) == 2
    front = np.unique(comp[inc.faces[(inc.face_layer == 0)][base.face_region == 0]])
    pocket = np.unique(comp[inc.faces[inc.face_layer == 1]])
    assert len(front) == 1 and len(pocket) == 1 and front[0] != pocket[0]
    # each switch point is now two vertices, one per piece, at the same rest position
    for p in ([20.0, 20.0], [40.0, 40.0]):
        at = np.nonzero(np.linalg.norm(inc.rest - p, axis=1) < 1e-9)[0]
        at = at[np.isin(at, inc.faces)]
        assert len(at) == 2 and len(np.unique(comp[at])) == 2
    assert count_flipped(inc.rest, inc.faces) == 0


@pytest.mark.parametrize("start", [0, 1])
def test_incision_no_junction_detaches_a_sheet(start):
    base, *_ = square_scene([])
    inc = incise(base, [alternating(np.zeros(0, np.int64), start)])
    rv = np.unique(base.F[base.face_region == 0])
    assert len(inc.rest) == len(base.V) + len(rv)
    comp = vertex_components(len(inc.rest), inc.faces)
    assert len(np.unique(comp)) == 2
    loops = boundary_loops(inc.faces)
    # The sewn sheet has no hole (front or pocket fills it): its outer rim and the detached sheet's rim.
    assert len(loops) == 2
    assert sorted(len(l) for l in loops) == sorted([len(region_boundary(base)), len(boundary_loops(base.F)[0])])
    # start 0: the pocket (layer 1) is the detached piece; start 1: the region's front is.
    pocket_comp = np.unique(comp[inc.faces[inc.face_layer == 1]])
    front_region_comp = np.unique(comp[base.F[base.face_region == 0]])
    outside_comp = np.unique(comp[inc.faces[(inc.face_layer == 0)][~(base.face_region == 0)]])
    assert len(pocket_comp) == 1 and len(outside_comp) == 1
    assert (pocket_comp[0] != outside_comp[0]) == (start == 0)
    assert (front_region_comp[0] != outside_comp[0]) == (start == 1)


def _path(base, sk, p0, p1):
    return handle_path(base, p0, p1, sk.parents)


def test_optimize_picks_the_lowest_energy():
    refined, sk, p0, p1 = capsule_scene()
    tpl = optimize_topology(refined, p0, p1, sk)
    base = build_template(refined, p0, sk)
    scored = [evaluate(base, [a], _path(base, sk, p0, p1)) for a in enumerate_assignments(20, refined.junctions[0])]
    energies = [e for e, *_ in scored]
    assert tpl.trials == 2
    assert np.isclose(tpl.energy, min(energies))
    assert tpl.cut_assignment[0].tolist() == ([0, 1] if energies[0] <= energies[1] else [1, 0])
    # the winner's deformation to the other pose is unfolded, at the recorded energy
    _, inc, steps, _ = scored[int(np.argmin(energies))]
    x = steps[-1][0]
    assert count_flipped(x, inc.faces) == 0
    d = Deformer(inc.rest, inc.faces, inc.handles)
    assert np.isclose(d.energy(x, tpl.handle_targets(p1)), tpl.energy)


def test_pose_path_follows_the_motion_to_the_other_pose():
    _, sk, p0, p1 = capsule_scene()
    path = pose_path(p0, p1, sk.parents, steps=4)
    assert len(path) == 4 and path[-1] is p1  # the last is the other pose itself, not a recomposition of it
    # the forearm turns about the elbow by equal angles, its length changes by equal amounts: never a straight
    # line between the hand's two positions
    ang = np.unwrap([np.arctan2(*(p[4, :2] - p[3, :2])[::-1]) for p in [p0, *path]])
    length = [np.linalg.norm(p[4, :2] - p[3, :2]) for p in [p0, *path]]
    assert np.allclose(np.diff(ang), np.diff(ang)[0]) and np.allclose(np.diff(length), np.diff(length)[0])
    assert np.allclose([p[:4] for p in path], p0[:4])


def tail_scene(n: int = 6, length: float = 100.0, rad: float = 7.0, bend: float = np.pi / 4):
    """A straight tail of n - 1 bones (128 px image) and a pose where every joint bends by `bend` (it curls)."""
    sk = Skeleton(joints=tuple(f"j{i}" for i in range(n)), parents=np.array([-1, *range(n - 1)]))
    seg = length / (n - 1)
    p0 = np.array([[14 + seg * i, 64, 0] for i in range(n)], float)
    p1, ang = p0.copy(), 0.0
    for i in range(1, n):
        ang += bend
        p1[i, :2] = p1[i - 1, :2] + seg * np.array([np.cos(ang), -np.sin(ang)])
    outer = capsule(p0[0, :2], p0[-1, :2], rad, 3)
    fg = np.zeros((128, 128), np.uint8)
    cv2.fillPoly(fg, [np.round(outer).astype(np.int32)], 1)
    refined = RefinedMasks(foreground=fg.astype(bool), occlusion=[], front_bones=[], boundaries=[], junctions=[],
                           domain=[outer], domain_holes=np.zeros((0, 2)), coverage=fg.astype(np.float32),
                           paper=np.ones((128, 128, 3), np.float32), colour=np.ones((128, 128, 3), np.float32))
    return refined, sk, p0, p1


def test_scoring_along_the_motion_finds_the_minimum_a_direct_solve_misses():
    # deformed straight from rest to the curled pose, L-BFGS stops in a crumpled minimum (7.5 against 4.1, after
    # ~1900 iterations); along the motion it reaches the minimum the lane's frame-by-frame deformation reaches
    refined, sk, p0, p1 = tail_scene()
    base = build_template(refined, p0, sk)
    inc = incise(base, [])
    d = Deformer(inc.rest, inc.faces, inc.handles)
    path = _path(base, sk, p0, p1)
    direct, along = d.solve(path[-1]), d.solve_along(path)
    assert along.converged and count_flipped(along.x, inc.faces) == 0
    assert along.energy < 0.75 * direct.energy and along.iterations < direct.iterations / 3
    template = Template(rest=inc.rest, faces=inc.faces, face_layer=inc.face_layer, handles=inc.handles,
                        handle_weights=base.handle_weights, handle_offsets=base.handle_offsets,
                        handle_frames=base.handle_frames, cut_assignment=[], energy=0.0, trials=0, mode="optimized")
    _, energies, _ = deform_sequence(template, np.stack([p0, *pose_path(p0, p1, sk.parents, steps=16)]))
    assert np.isclose(along.energy, energies[-1], rtol=1e-3)
    # the template stage scores exactly this deformation
    assert np.isclose(optimize_topology(refined, p0, p1, sk).energy, along.energy, rtol=1e-6)


def test_the_template_keeps_the_searchs_solution_at_each_target_and_the_texture_solve_starts_there():
    # the textured template deforms the template to the other key's pose to see which pockets that key shows: from
    # rest it stopped in the crumpled minimum above after ~1900 iterations; from the search's solution along the
    # motion (Template.target_x) it starts at the minimum the lane's frames reach
    refined, sk, p0, p1 = tail_scene()
    tpl = optimize_topology(refined, p0, p1, sk)
    (x,) = tpl.target_x
    assert x.shape == tpl.rest.shape and count_flipped(x, tpl.faces) == 0
    assert np.isclose(Deformer(tpl.rest, tpl.faces, tpl.handles).energy(x, tpl.handle_targets(p1)), tpl.energy)
    assert [t.shape for t in optimize_topology(refined, p0, [p1, p0], sk).target_x] == [x.shape, x.shape]
    ink = make_inpainter("telea", 3)
    _, from_search = texture_lane(tpl, refined, refined, p0, p1, ink, start=x)
    _, from_rest = texture_lane(tpl, refined, refined, p0, p1, ink)
    assert np.isclose(from_search, tpl.energy, rtol=1e-3) and from_search < 0.75 * from_rest
    # a start that is not this template's (another mesh's vertices) is ignored: from rest
    assert texture_lane(tpl, refined, refined, p0, p1, ink, start=x[:-1])[1] == from_rest


def test_cusp_families_cover_exactly_the_odd_assignments():
    for n, junctions in [(8, [3]), (9, [1, 4, 6]), (11, [0, 1, 5, 8, 9]), (7, [6])]:
        jn = np.array(junctions)
        stretches = cusp_stretches(n, jn)
        assert sorted(np.concatenate(stretches).tolist()) == sorted(set(range(n)) - set(junctions))
        for idx in stretches:  # consecutive along the loop, between two consecutive junctions
            assert all((b - a) % n == 1 for a, b in zip(idx[:-1], idx[1:]))
        family = set()
        for idx in stretches:
            for c in idx:
                for label in (0, 1):
                    a = cusp_assignment(jn, int(c), label)
                    # the segment starting at the first junction carries the family's label
                    assert segment_labels(a, np.array([jn.min() + 0.5]))[0] == label and a.cusp == c
                    family.add(edge_labels(a, n))
        assert family == {edge_labels(a, n) for a in enumerate_assignments(n, jn)}
        assert len(family) == count_assignments(n, len(jn))


def test_the_other_cut_starts_from_its_neighbour_with_front_and_pocket_swapped():
    # the other cut of an even region sews the pocket where the front was: carried corner by corner its
    # neighbour's solution folds there, with the region's front and pocket faces swapped it is fold-free, and
    # solved from there it reaches (within 1%: a neighbouring minimum) the energy the path from rest reaches
    refined, sk, p0, p1 = capsule_scene()
    base = build_template(refined, p0, sk)
    search = _Search(base, [_path(base, sk, p0, p1)], Solver())
    a, b = alternating(base.junctions[0], 0), alternating(base.junctions[0], 1)
    first = search.score([a])
    inc_b = incise(base, [b])
    for x, _ in first.steps[0]:  # at every step of the motion
        plain = transfer_positions(x, first.inc.faces, inc_b.faces, inc_b.rest)
        assert count_flipped(plain, inc_b.faces) > 0
    x0, limit, step = search._warm_start([b], [next(iter(search.cache))], 0)
    assert x0 is not None and count_flipped(x0, inc_b.faces) == 0
    assert limit == WARM_START_LIMIT * first.steps[0][step][1]
    assert Deformer(inc_b.rest, inc_b.faces, inc_b.handles).energy(x0, search.paths[0][step]) <= limit
    scored = search.score([b], [next(iter(search.cache))])
    assert scored.warm and np.isclose(scored.energy, evaluate(base, [b], search.paths[0])[0], rtol=1e-2)
    # without a usable neighbour (no solution to carry) the cut is deformed from rest along the motion
    cold = _Search(base, search.paths, Solver())
    cold.cache[_key([a])] = type(first)(np.inf, first.inc, [a], [[None] * len(search.paths[0])], [np.inf], False)
    assert not cold.score([b], [_key([a])]).warm


def test_a_start_crumpled_at_the_other_pose_is_carried_over_earlier_along_the_motion():
    # the capsule's other cut, carried over from its neighbour's solution at the other key's pose, starts crumpled
    # (above the limit); a quarter of the way there the sheets have not parted yet and it carries over within the
    # limit: solved from that step on, it reaches the energy the path from rest reaches
    refined, sk, p0, p1 = capsule_scene()
    base = build_template(refined, p0, sk)
    path = _path(base, sk, p0, p1)
    search = _Search(base, [path], Solver())
    a, b = alternating(base.junctions[0], 0), alternating(base.junctions[0], 1)
    first = search.score([a])
    inc_b = incise(base, [b])
    d = Deformer(inc_b.rest, inc_b.faces, inc_b.handles, method="newton")
    swapped = search._source_faces([b], first)
    last = transfer_positions(first.steps[0][-1][0], swapped, inc_b.faces, inc_b.rest)
    assert d.energy(last, path[-1]) > WARM_START_LIMIT * first.energies[0]
    x0, limit, step = search._warm_start([b], [_key([a])], 0)
    assert 0 <= step < len(path) - 1 and d.energy(x0, path[step]) <= limit
    energy, _, steps, warm = evaluate(base, [b], path, Solver(), x0, limit, step)
    assert warm and steps[:step] == [None] * step and all(s is not None for s in steps[step:])
    assert np.isclose(energy, d.solve_along(path).energy, rtol=1e-3)


def test_nonmanifold_edges_are_counted_as_by_brute_force():
    from collections import Counter

    from ops.geometry.topology import _nonmanifold_warning

    rng = np.random.default_rng(5)
    for n in (4, 30, 400):
        F = rng.integers(0, n, (3 * n, 3))
        F = F[(F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])]
        edges = Counter(tuple(sorted((int(f[i]), int(f[(i + 1) % 3])))) for f in F for i in range(3))
        bad = sum(c > 2 for c in edges.values())
        assert _nonmanifold_warning(F) == ([f"{bad} non-manifold edge(s) where switch vertices are adjacent"]
                                           if bad else [])
    assert _nonmanifold_warning(np.zeros((0, 3), np.int64)) == []


def test_a_candidate_warm_starts_from_any_topology_its_region_tried_before():
    # an odd region's probes move the cusp along the boundary: the topology that carries over to a later probe
    # may be one tried several probes earlier (arm_cross's key1 with five more T-junctions: the sixth probe
    # carried over only from the second, 0.066 -> 0.040 s). Four later topologies that carry nothing sit between
    refined, sk, p0, p1 = capsule_scene()
    base = build_template(refined, p0, sk)
    search = _Search(base, [_path(base, sk, p0, p1)], Solver())
    a, b = alternating(base.junctions[0], 0), alternating(base.junctions[0], 1)
    region = _Region(search, [a], 0, deadline=np.inf)
    region.energy(a)
    first = search.cache[_key([a])]
    for i in range(4):  # solved nowhere along the motion: nothing to carry over
        fake = alternating(np.array([i, i + 20]), 0)
        search.cache[_key([fake])] = type(first)(np.inf, first.inc, [fake], [[None] * len(search.paths[0])],
                                                 [np.inf], False)
        region.tried.append(_key([fake]))
    region.energy(b)
    assert search.cache[_key([b])].warm


@pytest.mark.parametrize("limit, warm", [(np.inf, True), (1.0, False)])
def test_a_crumpled_warm_start_is_solved_from_rest(monkeypatch, limit, warm):
    # the carried-over start of the other cut begins above its neighbour's energy (crumpled near the cut): with no
    # limit it is solved from there, with a limit of 1x from rest along the motion; both reach the same minimum
    import ops.geometry.topology as topology

    monkeypatch.setattr(topology, "WARM_START_LIMIT", limit)
    refined, sk, p0, p1 = capsule_scene()
    base = build_template(refined, p0, sk)
    search = _Search(base, [_path(base, sk, p0, p1)], Solver())
    a, b = alternating(base.junctions[0], 0), alternating(base.junctions[0], 1)
    search.score([a])
    scored = search.score([b], [_key([a])])
    assert scored.warm == warm
    assert np.isclose(scored.energy, evaluate(base, [b], search.paths[0])[0], rtol=1e-2)


def test_two_targets_sum_the_energies_of_each():
    """A key between two neighbours: each cut's energy is the sum of its energies towards each pose."""
    refined, sk, p0, p1 = capsule_scene()
    base = build_template(refined, p0, sk)
    both = _Search(base, [_path(base, sk, p0, p1), _path(base, sk, p0, p1)], Solver())
    one = _Search(base, [_path(base, sk, p0, p1)], Solver())
    a = alternating(base.junctions[0], 0)
    assert np.isclose(both.score([a]).energy, 2 * one.score([a]).energy, rtol=1e-9)
    tpl = optimize_topology(refined, p0, [p1, p1], sk)
    assert np.isclose(tpl.energy, 2 * optimize_topology(refined, p0, p1, sk).energy, rtol=1e-6)


@pytest.mark.parametrize("junctions", [(5,), (2, 8, 14), (1, 5, 9, 13, 17)])
def test_odd_search_grows_linearly_with_the_junctions(junctions):
    refined, sk, p0, p1 = capsule_scene(junctions=junctions)
    tpl = optimize_topology(refined, p0, p1, sk)
    k = len(junctions)
    assert tpl.trials <= 2 * k + MAX_CUSP_MOVES  # the 2k probes, then the best family's walk
    assert count_flipped(tpl.rest, tpl.faces) == 0
    switches = tpl.cut_switches[0]
    assert len(switches) == k + 1 and set(junctions) < set(switches.tolist())
    # the recorded cut is the switching rule's: labels alternate at the switches, its energy is reproducible
    base = build_template(refined, p0, sk)
    cusp = int(np.setdiff1d(switches, junctions)[0])
    a = Assignment(switches=switches, labels=tpl.cut_assignment[0], cusp=cusp)
    assert np.array_equal(a.labels, alternating(switches, int(a.labels[0])).labels)
    e, *_ = evaluate(base, [a], _path(base, sk, p0, p1))
    assert np.isclose(e, tpl.energy, rtol=1e-3)


def two_region_scene(junctions=((3, 12), (2, 9))):
    """The capsule scene with a second occlusion region: the upper arm (shoulder-elbow) drawn over the torso."""
    refined, sk, p0, p1 = capsule_scene(junctions=junctions[0])
    upper = capsule(p0[2, :2], p0[3, :2], 5, 2)
    refined.boundaries.append(upper)
    refined.junctions.append(np.array(junctions[1], np.int64))
    refined.front_bones.append(np.array([2]))
    mask = np.zeros_like(refined.occlusion[0], np.uint8)
    cv2.fillPoly(mask, [np.round(upper).astype(np.int32)], 1)
    refined.occlusion.append(mask.astype(bool))
    return refined, sk, p0, p1


def test_unchanged_regions_keep_their_cuts():
    refined, sk, p0, p1 = two_region_scene()
    first = optimize_topology(refined, p0, p1, sk)
    assert first.reused_regions == [] and len(first.region_keys) == 2 and first.trials >= 3
    again = optimize_topology(refined, p0, p1, sk, previous=first)
    assert again.reused_regions == [0, 1] and again.trials == 0  # nothing deformed: the same template, exactly
    assert again.energy == first.energy and all(np.array_equal(a, b) for a, b in zip(again.target_x, first.target_x))
    assert np.array_equal(again.rest, first.rest) and np.array_equal(again.faces, first.faces)
    assert [c.tolist() for c in again.cut_assignment] == [c.tolist() for c in first.cut_assignment]
    assert [c.tolist() for c in again.cut_switches] == [c.tolist() for c in first.cut_switches]
    assert any("without searching" in w for w in again.warnings)
    # a click moved in region 1: region 0 keeps its cut, region 1 is searched again
    moved = two_region_scene(junctions=((3, 12), (2, 10)))[0]
    edited = optimize_topology(moved, p0, p1, sk, previous=first)
    assert edited.reused_regions == [0] and edited.region_keys[0] == first.region_keys[0]
    assert edited.region_keys[1] != first.region_keys[1] and edited.trials == 2
    # another pose to score against changes every region
    other = p1.copy()
    other[4, 1] += 3.0
    assert optimize_topology(refined, p0, other, sk, previous=first).reused_regions == []


def test_a_region_out_of_budget_keeps_the_best_cut_so_far():
    refined, sk, p0, p1 = capsule_scene(junctions=(2, 8, 14))
    tpl = optimize_topology(refined, p0, p1, sk, solver=Solver(region_budget_s=0.0))
    assert tpl.budget_regions == [0] and tpl.trials == 1  # the region's first topology only
    assert any("budget" in w for w in tpl.warnings) and np.isfinite(tpl.energy)
    assert count_flipped(tpl.rest, tpl.faces) == 0
    full = optimize_topology(refined, p0, p1, sk)
    assert full.budget_regions == [] and full.trials > 1 and full.energy <= tpl.energy + 1e-9


@pytest.mark.slow  # seconds, not milliseconds: the whole suite runs it, the edit loop does not
def test_odd_search_finds_the_exhaustive_minimum_and_is_reproducible():
    refined, sk, p0, p1 = capsule_scene(junctions=(5,))
    a = optimize_topology(refined, p0, p1, sk)
    b = optimize_topology(refined, p0, p1, sk)
    assert [x.tolist() for x in a.cut_switches] == [x.tolist() for x in b.cut_switches]
    assert a.energy == b.energy and a.trials == b.trials
    base = build_template(refined, p0, sk)
    path = _path(base, sk, p0, p1)
    every = [evaluate(base, [o], path)[0] for o in enumerate_assignments(20, np.array([5]))]
    assert a.trials < len(every) / 2  # 38 cuts, far fewer deformed
    assert a.energy <= min(every) * (1 + 2e-3)


def test_a_template_stored_by_other_code_gives_no_cuts_to_keep(tmp_path):
    """The run hands the search its stored template only when the same code made it: a region's key digests
    what its search read, not how it searched, so a changed search must search again (assets/geometry.py)."""
    import assets.stages  # noqa: F401  (declares the stages: their code records)
    from assets.compute import STAGE_SPECS
    from assets.geometry import _previous_template
    from resources.store import Store

    refined, sk, p0, p1 = two_region_scene()
    template = optimize_topology(refined, p0, p1, sk)
    store, name = Store(tmp_path), "key1/template"
    env = types.SimpleNamespace(store=store, partition="shot", code=None)  # None: the stage's record computed
    assert _previous_template(env, 1) is None  # nothing stored yet
    code = dict(STAGE_SPECS[name].code)
    store.write(name, "shot", template, provenance={"parents": {}, "settings": {}, "code": code})
    kept = _previous_template(env, 1)
    assert kept is not None and kept.region_keys == template.region_keys
    env.code = dict(code)  # the record the run compares by, when run_stage has set it
    assert _previous_template(env, 1) is not None
    code["ops/geometry/topology.py"] = "an older search"
    store.write(name, "shot", template, provenance={"parents": {}, "settings": {}, "code": code})
    assert _previous_template(env, 1) is None
    env.code = None
    assert _previous_template(env, 1) is None


def _scripted_region(energy_of):
    """A region whose cuts' energies come from energy_of(assignment) instead of deformations."""
    return types.SimpleNamespace(energy=lambda a, neighbours=(): energy_of(a))


def test_a_tie_keeps_the_cut_tried_first():
    jn = np.array([3, 12])
    a, b = alternating(jn, 0), alternating(jn, 1)
    for eb, want in ((1.0 - 0.5 * TIE, a), (1.0 - 2 * TIE, b), (1.0 + 1e-9, a)):
        got = _search_even(_scripted_region(lambda x, eb=eb: 1.0 if x.labels[0] == a.labels[0] else eb), jn)
        assert np.array_equal(got.labels, want.labels)
    assert lower(1.0, np.inf) and not lower(np.inf, 1.0) and not lower(1.0 - TIE / 2, 1.0)


def test_the_cusp_search_chooses_the_same_cut_whatever_the_last_bits():
    """Two families tie at the least energy (as a region that never opens does) and the cusp's energy is flat
    near its minimum: energies perturbed far below the tie (another CPU's kernels) choose the same cut, and the
    choice is within a tie of the least energy the search saw."""
    n, jn = 40, np.array([3, 17, 29])
    rng = np.random.default_rng(3)

    def energy(a: Assignment, noise: float, seen: list) -> float:
        stretch = int(np.searchsorted(jn, a.cusp)) % 3  # the stretch after the T-junction before it
        label_at_first = int(segment_labels(a, np.array([jn[0] + 0.5]))[0])
        e = 5.0 + 0.5 * (stretch == 2) + (0.0 if stretch == 0 else 0.3 * label_at_first) + 1e-6 * (a.cusp % 7)
        e *= 1 + noise * rng.standard_normal()
        seen.append(e)
        return e

    chosen = set()
    for noise in (0.0, 1e-9, 1e-8, 1e-7):
        for _ in range(5):
            seen: list[float] = []
            got = _search_odd(_scripted_region(lambda a: energy(a, noise, seen)), n, jn)
            chosen.add((tuple(got.switches.tolist()), tuple(got.labels.tolist())))
            assert energy(got, 0.0, []) <= min(seen) * (1 + 2 * TIE)
    assert len(chosen) == 1
