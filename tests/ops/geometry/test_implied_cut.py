"""Tests of ops.geometry.implied_cut: the cut a region's outline implies, where the user clicked no T-junction."""
import cv2
import numpy as np

from ops.geometry.implied_cut import MIN_RUN_PX, implied_labels, outward_probes, switches_of
from ops.geometry.template import build_template
from ops.geometry.topology import Solver, _key, alternating, implied_cut, optimize_topology, segment_labels
from ops.types import Skeleton
from tests.ops.geometry.test_template import capsule_scene

# a torso (hips-neck, bone 0) and a forearm across it (elbow-hand, bone 2) behind a short upper arm (bone 1)
SKELETON = Skeleton(joints=("hips", "neck", "elbow", "hand"), parents=np.array([-1, 0, 1, 2]))


def rectangle(x0, y0, x1, y1, step=2.0):
    """(n, 2) closed polyline around [x0, x1] x [y0, y1], counter-clockwise on screen, a vertex every ~step px."""
    def edge(a, b):
        k = max(int(np.ceil(np.linalg.norm(np.subtract(b, a)) / step)), 1)
        return np.linspace(a, b, k + 1)[:-1]
    corners = [(x0, y0), (x0, y1), (x1, y1), (x1, y0)]
    return np.concatenate([edge(corners[i], corners[(i + 1) % 4]) for i in range(4)])


def bar_over_body():
    """A vertical forearm (x 60-70) across a wide body (y 40-80): the region is their 10 x 40 overlap."""
    fg = np.zeros((128, 128), bool)
    fg[40:81, 20:109] = True  # the body
    fg[10:121, 60:71] = True  # the forearm, sticking out above and below
    region = np.zeros_like(fg)
    region[40:81, 60:71] = True
    boundary = rectangle(59.5, 39.5, 70.5, 80.5)
    pose = np.array([[64, 60, 0], [40, 60, 0], [65, 5, -1], [65, 125, -1]], float)  # torso along y = 60
    return boundary, region, fg, pose


def test_the_covering_limbs_ends_stay_sewn_and_its_sides_are_cut():
    """Across the region's top and bottom the forearm goes on (0); across its sides only the body does (1)."""
    boundary, region, fg, pose = bar_over_body()
    labels = implied_labels(boundary, region, fg, np.array([2]), pose, SKELETON)
    ends = (boundary[:, 1] < 40) | (boundary[:, 1] > 80)
    sides = ((boundary[:, 0] < 60) | (boundary[:, 0] > 70)) & ~ends
    middle_of_ends = ends & (np.abs(boundary[:, 0] - 65) < 3)
    middle_of_sides = sides & (np.abs(boundary[:, 1] - 60) < 15)
    assert (labels[middle_of_ends] == 0).all() and (labels[middle_of_sides] == 1).all()
    switches, seg = switches_of(labels)
    assert len(switches) == 4  # the four T-junctions, one near each corner of the overlap
    corners = np.array([[59.5, 39.5], [59.5, 80.5], [70.5, 80.5], [70.5, 39.5]])
    d = np.linalg.norm(boundary[switches][:, None] - corners[None], axis=2).min(axis=0)
    assert (d <= 4.0).all()


def test_probes_lie_outside_whichever_way_the_polyline_runs():
    boundary, region, _, _ = bar_over_body()
    for loop in (boundary, boundary[::-1]):
        probes = outward_probes(loop, region)
        c = np.round(probes).astype(int)
        assert not region[c[:, 1], c[:, 0]].any()


def test_paper_takes_its_neighbours_label_and_short_runs_join_theirs():
    """A region on the silhouette: probes on paper read nothing and take the nearer label; a blip shorter than
    MIN_RUN_PX is noise."""
    boundary, region, fg, pose = bar_over_body()
    fg2 = fg.copy()
    fg2[:, 71:] = False  # the body ends at the forearm's right side: those probes are on paper
    labels = implied_labels(boundary, region, fg2, np.array([2]), pose, SKELETON)
    assert len(switches_of(labels)[0]) in (2, 4)  # paper never makes a run of its own
    seg = np.linalg.norm(np.roll(boundary, -1, axis=0) - boundary, axis=1)
    starts = np.nonzero(labels != np.roll(labels, 1))[0]
    for s, e in zip(starts, np.roll(starts, -1)):
        run = np.arange(s, e if e > s else e + len(labels)) % len(labels)
        assert seg[run].sum() >= MIN_RUN_PX


def test_switches_of_round_trips_through_segment_labels():
    labels = np.array([0, 0, 1, 1, 1, 0, 1, 1, 0, 0], np.int8)
    switches, seg = switches_of(labels)
    assert switches.tolist() == [2, 5, 6, 8] and seg.tolist() == [1, 0, 1, 0]
    a = alternating(switches, int(seg[0]))
    np.testing.assert_array_equal(segment_labels(a, np.arange(10) + 0.5), labels)
    assert switches_of(np.ones(5, np.int8))[0].size == 0


def test_a_region_without_clicks_keeps_the_cheapest_of_its_uniform_and_implied_cuts():
    """The capsule scene's forearm region with its T-junctions removed: the search tries the two uniform cuts and
    the implied one (hinged at the elbow), and keeps the one of least energy; the implied cut frees the forearm's
    sides, so it deforms to the swung-down pose with less energy than the front sewn all round."""
    refined, sk, pose0, pose1 = capsule_scene(junctions=())
    base = build_template(refined, pose0, sk)
    implied = implied_cut(base, refined, 0, pose0, sk)
    assert implied is not None and len(implied.switches) >= 2
    solver = Solver()
    tpl = optimize_topology(refined, pose0, pose1, sk, solver=solver)
    clicked = optimize_topology(refined, pose0, pose1, sk, solver=solver, implied_cuts=False)
    assert tpl.trials == 3 and clicked.trials == 2
    assert tpl.energy <= clicked.energy + 1e-9
    sewn = optimize_topology(refined, pose0, pose1, sk, solver=solver, implied_cuts=False)
    chosen = (tuple(tpl.cut_switches[0].tolist()), tuple(tpl.cut_assignment[0].tolist()))
    assert chosen in {_key([implied])[0], _key([alternating(np.zeros(0, np.int64), 0)])[0],
                      _key([alternating(np.zeros(0, np.int64), 1)])[0]}
    assert sewn.energy == clicked.energy


def test_the_capsule_forearm_is_hinged_at_its_elbow():
    """Whole inside the torso, the forearm region's outline is the forearm's own: only where the upper arm goes on
    (the elbow's cap) does the front stay sewn."""
    refined, sk, pose0, _ = capsule_scene(junctions=())
    labels = implied_labels(refined.boundaries[0], refined.occlusion[0], refined.foreground, refined.front_bones[0],
                            pose0, sk)
    elbow, hand = pose0[3, :2], pose0[4, :2]
    b = refined.boundaries[0]
    near_elbow = np.linalg.norm(b - elbow, axis=1) < np.linalg.norm(b - hand, axis=1) - 8
    assert labels[~near_elbow].mean() > 0.8 and (labels == 0).any()
    assert cv2.pointPolygonTest(np.round(b).astype(np.int32), tuple(map(float, elbow)), False) >= 0
