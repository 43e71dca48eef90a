"""Warnings that name their subject: the line `about` writes is the line `parse` reads back, and the stages'
warnings about a T-junction, a joint or a bone name it where it is."""
from __future__ import annotations

import numpy as np
import pytest

from ops.segmentation.junctions import assign_junctions
from ops.segmentation.masks import pose_warnings
from ops.segmentation.occlusion import _pair_overlaps
from ops.types import Skeleton
from ops.warning_subject import KINDS, about, inside_point, parse


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_round_trips_with_name_position_and_fix(kind):
    text = about(kind, "lies far outside the foreground (9.2 px); kept", name="r_hand", at=(120.04, -3.5),
                 fix="move it onto the drawing")
    s = parse(text)
    assert s is not None and s.kind == kind and s.names == ("r_hand",) and s.index is None
    assert s.at == (120.0, -3.5)
    assert s.problem == "lies far outside the foreground (9.2 px); kept" and s.fix == "move it onto the drawing"


def test_index_several_names_and_no_position():
    s = parse(about("occlusion region", "has 2 pieces", name=3))
    assert (s.kind, s.index, s.names, s.at, s.fix) == ("occlusion region", 3, (), None, None)
    s = parse(about("bones", "overlap", name=("hip-knee", "spine-neck"), at=(1, 2)))
    assert s.names == ("hip-knee", "spine-neck") and s.at == (1.0, 2.0)
    # a name holding the separators still comes back whole
    assert parse(about("joint", "x", name="a: b", at=(0, 0))).names == ("a: b",)


def test_a_warning_about_the_whole_keyframe_has_no_subject():
    assert parse("merged 2 duplicate input vertex(es)") is None
    assert parse("no topology deformed to the other keyframe's pose without failure") is None
    with pytest.raises(ValueError):
        about("elbow", "x")


def test_inside_point_is_the_centre_of_a_square_and_none_for_nothing():
    m = np.zeros((40, 60), bool)
    m[10:21, 30:41] = True  # 11 x 11 pixels: centre (35, 15), the one pixel 6 px from the edge
    m[0:3, 0:3] = True  # a smaller piece elsewhere does not pull it away
    assert inside_point(m) == (35.0, 15.0)
    assert inside_point(np.zeros((5, 5), bool)) is None


def test_t_junction_warnings_name_the_click_where_it_was_made():
    fg = np.zeros((80, 80), bool)
    fg[10:70, 10:70] = True
    region = np.zeros_like(fg)
    region[30:50, 50:70] = True
    pose = np.array([[20.0, 40.0, 0.0], [60.0, 40.0, -1.0]])
    stick = Skeleton(joints=("a", "b"), parents=np.array([-1, 0]))
    clicks = np.array([[72.0, 40.0], [15.0, 15.0]])  # 3 px off the drawing; far from the region
    *_, warnings = assign_junctions(clicks, [region], [np.array([0])], fg, pose, stick)
    subjects = [parse(w) for w in warnings]
    assert all(s is not None and s.kind == "T-junction" for s in subjects), warnings
    assert {s.at for s in subjects} == {(72.0, 40.0), (15.0, 15.0)}
    grown = next(s for s in subjects if "grown" in s.problem)
    assert grown.at == (15.0, 15.0)


def test_joint_off_the_foreground_is_named_and_placed():
    fg = np.zeros((50, 50), bool)
    fg[10:40, 10:40] = True
    sk = Skeleton(joints=("hips", "hand"), parents=np.array([-1, 0]))
    pose = np.array([[25.0, 25.0, 0.0], [48.0, 25.0, 0.0]])  # the hand 9 px right of the foreground
    subjects = [parse(w) for w in pose_warnings(fg, pose, sk)]
    hand = next(s for s in subjects if s.kind == "joint")
    assert hand.names == ("hand",) and hand.at == (48.0, 25.0) and "far outside" in hand.problem
    assert not [s for s in subjects if s.kind == "bone"]  # the bone's midpoint (36.5, 25) is inside
    pose[0] = [46.0, 45.0, 0.0]  # now the midpoint (47, 35) is off too
    bone = next(s for s in map(parse, pose_warnings(fg, pose, sk)) if s.kind == "bone")
    assert bone.names == ("hips-hand",) and bone.at == (47.0, 35.0) and bone.problem.startswith("midpoint lies far")


def test_equal_depth_overlap_is_one_warning_per_pair_at_the_overlap():
    sk = Skeleton(joints=("a", "b", "c", "d"), parents=np.array([-1, 0, 1, 2]))  # bones a-b, b-c, c-d
    thick = np.zeros((3, 30, 30), bool)
    thick[0, 5:15, 5:15] = True  # bone a-b
    thick[2, 10:20, 10:20] = True  # bone c-d, not adjacent to a-b; overlap rows/cols 10..14
    _, warnings = _pair_overlaps(thick, np.zeros(3), sk)
    assert len(warnings) == 1
    s = parse(warnings[0])
    assert s.kind == "bones" and s.names == ("a-b", "c-d") and s.fix.startswith("give the joints different z")
    assert s.at == (12.0, 12.0) and "equal depth" in s.problem
    # an overlap smaller than a region the prediction keeps (25 px here) is noise, not a warning
    assert _pair_overlaps(thick, np.zeros(3), sk, min_px=26)[1] == []
    assert len(_pair_overlaps(thick, np.zeros(3), sk, min_px=25)[1]) == 1
