"""The puppet that films the real-drawing shots (benchmarks/puppet.py), on a generated stick figure: the rest pose
is the drawing, parts away from joints move rigidly with their bones, depth decides which part shows where two
overlap, and everything is deterministic; realdev_shots.py films and writes a shot the loader accepts."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from benchmarks import realdev_shots
from benchmarks.heldout_shots import check_shot
from benchmarks.puppet import build_rig, moving_together, render, rigid_maps, skeleton_bones
from benchmarks.realdev_shots import FRAMES, Character, Window, film, write_shot

PAPER = (0.93, 0.91, 0.86)
RED, BLUE, GREEN, BROWN = (0.8, 0.1, 0.1), (0.1, 0.2, 0.8), (0.1, 0.6, 0.2), (0.5, 0.3, 0.1)
MARK_ARM, MARK_LEG = (0.9, 0.1, 0.9), (0.1, 0.9, 0.9)
#           0 root      1 hip       2 torso     3 neck      4 r_shoulder 5 r_elbow  6 r_hand
REST = np.array([[64, 92], [64, 92], [64, 52], [64, 38], [56, 54], [40, 54], [20, 54],
                 # 7 r_hip   8 r_knee   9 r_foot
                 [58, 94], [56, 108], [56, 122]], np.float64)
PARENTS = np.array([-1, 0, 1, 2, 2, 4, 5, 0, 7, 8])
JOINTS = ("root", "hip", "torso", "neck", "right_shoulder", "right_elbow", "right_hand", "right_hip", "right_knee",
          "right_foot")
BLEND = 3.0
ARM_MARK = (28, 54)  # the forearm's middle, far from both of its joints
LEG_MARK = (56, 116)  # the shin's middle


def stick_figure() -> tuple[np.ndarray, np.ndarray]:
    """(128, 128, 3) float32 drawing on paper and its (128, 128) bool mask: a red torso, a blue head, a green arm,
    a brown leg, a 3 x 3 marker on the forearm and on the shin."""
    img = np.zeros((128, 128, 3), np.float32)
    img[:] = PAPER

    def line(a, b, colour, width):
        cv2.line(img, tuple(int(v) for v in REST[a]), tuple(int(v) for v in REST[b]), colour, width)

    cv2.rectangle(img, (52, 44), (76, 96), RED, -1)
    cv2.circle(img, (64, 30), 9, BLUE, -1)
    line(4, 5, GREEN, 7)
    line(5, 6, GREEN, 7)
    line(7, 8, BROWN, 7)
    line(8, 9, BROWN, 7)
    for (x, y), colour in ((ARM_MARK, MARK_ARM), (LEG_MARK, MARK_LEG)):
        img[y - 1:y + 2, x - 1:x + 2] = colour
    mask = np.any(np.abs(img - np.float32(PAPER)) > 1e-3, axis=2)
    return img, mask


def rig_of(img: np.ndarray, mask: np.ndarray, group: np.ndarray | None = None):
    background = img.copy()
    background[mask] = PAPER
    return build_rig(img, background, mask, REST, PARENTS, BLEND, group)


def posed(arm_deg: float, elbow_deg: float, knee_deg: float, arm_z: float = 0.0) -> np.ndarray:
    """(J, 3) pose: the upper arm turned about the shoulder, the forearm further about the elbow, the shin about
    the knee (degrees, image axes); z = arm_z at the arm's joints, 0 elsewhere."""
    pose = np.c_[REST, np.zeros(len(REST))]

    def turn(joints, centre, deg):
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        rot = np.array([[c, -s], [s, c]])
        pose[joints, :2] = (pose[joints, :2] - pose[centre, :2]) @ rot.T + pose[centre, :2]

    turn([5, 6], 4, arm_deg)
    turn([6], 5, elbow_deg)
    turn([9], 8, knee_deg)
    pose[[5, 6], 2] = arm_z
    return pose


def centroid(image: np.ndarray, colour) -> np.ndarray:
    """(x, y) mean position of the pixels within 0.05 of a colour in every channel."""
    ys, xs = np.nonzero(np.all(np.abs(image - np.float32(colour)) < 0.05, axis=2))
    assert len(xs) > 0, f"colour {colour} not found"
    return np.array([xs.mean(), ys.mean()])


@pytest.fixture(scope="module")
def figure():
    img, mask = stick_figure()
    return img, mask, rig_of(img, mask)


def test_the_rest_pose_is_the_drawing_exactly(figure):
    img, _, rig = figure
    out = render(rig, np.c_[REST, np.zeros(len(REST))])
    assert np.array_equal(out.image, img)
    assert not out.crossing.any()


def test_parts_move_rigidly_with_their_bones_away_from_joints(figure):
    img, _, rig = figure
    pose = posed(arm_deg=-50.0, elbow_deg=-40.0, knee_deg=35.0)
    out = render(rig, pose)
    bones = skeleton_bones(REST, PARENTS)
    maps = rigid_maps(REST, PARENTS, bones, pose)
    for mark, colour, joint in ((ARM_MARK, MARK_ARM, 6), (LEG_MARK, MARK_LEG, 9)):
        k = int(np.nonzero(bones == joint)[0][0])
        expected = maps[k, :, :2] @ centroid(img, colour) + maps[k, :, 2]
        assert np.linalg.norm(centroid(out.image, colour) - expected) < 1.0
        assert np.linalg.norm(expected - np.asarray(mark)) > 3.0  # it did move
    # the torso, whose bone did not move, is where it was drawn
    assert np.array_equal(out.image[60:90, 58:72], img[60:90, 58:72])


def test_joints_bend_without_tearing(figure):
    """A limb bent at its elbow keeps its ink continuous: along the bent arm's bones no pixel shows paper."""
    _, _, rig = figure
    pose = posed(arm_deg=-20.0, elbow_deg=-70.0, knee_deg=0.0)
    out = render(rig, pose)
    for a, b in ((4, 5), (5, 6)):
        for t in np.linspace(0.05, 0.95, 40):
            x, y = np.round(pose[a, :2] + t * (pose[b, :2] - pose[a, :2])).astype(int)
            assert np.abs(out.image[y, x] - np.float32(PAPER)).max() > 0.1, (a, b, t)


def test_depth_decides_which_part_shows_where_two_overlap(figure):
    _, _, rig = figure
    x, y = 60, 66  # inside the torso; the lowered forearm crosses it there
    for z, colour, crossing in ((-1.0, GREEN, True), (1.0, RED, True)):
        out = render(rig, posed(arm_deg=-100.0, elbow_deg=-70.0, knee_deg=0.0, arm_z=z))
        assert np.abs(out.image[y, x] - np.float32(colour)).max() < 0.05, (z, out.image[y, x])
        assert out.crossing[y, x] == crossing
    near = render(rig, posed(arm_deg=-100.0, elbow_deg=-70.0, knee_deg=0.0, arm_z=-1.0))
    assert JOINTS[rig.bones[near.front[y, x]]] in ("right_elbow", "right_hand")
    assert JOINTS[rig.bones[near.covered[y, x]]] == "torso"


def test_deterministic(figure):
    img, mask, rig = figure
    again = rig_of(img, mask)
    assert np.array_equal(again.labels, rig.labels) and np.array_equal(again.corner_weights, rig.corner_weights)
    pose = posed(arm_deg=-60.0, elbow_deg=-30.0, knee_deg=20.0, arm_z=-1.0)
    assert np.array_equal(render(rig, pose).image, render(again, pose).image)


def test_bones_that_move_as_one_make_one_part():
    """Collarbone-like bones that keep their angle to their parent in every pose join its part."""
    motion = np.stack([posed(a, 0.0, 0.0) for a in (0.0, -30.0)])
    group = moving_together(REST, PARENTS, motion)
    bones = [JOINTS[j] for j in skeleton_bones(REST, PARENTS)]
    part = dict(zip(bones, group))
    assert part["right_elbow"] == part["right_hand"]  # the arm turns as one piece in this motion
    assert part["right_elbow"] != part["torso"]
    assert part["torso"] == part["neck"] == part["right_shoulder"]  # none of these ever turn


def test_a_filmed_shot_loads_and_is_deterministic(tmp_path, monkeypatch):
    monkeypatch.setattr(realdev_shots, "SIZE", 96)  # the shots' 256 px, smaller: the same code, faster
    img, mask = stick_figure()
    ch = Character("stick", img, mask, JOINTS, PARENTS, REST)
    motion = np.stack([posed(-10.0 * i, -8.0 * i, 4.0 * i, arm_z=-1.0) for i in range(FRAMES)])
    window = Window(0, 1, 1.0, (0.0,) * FRAMES, 1.0)
    shots = []
    for k in range(2):
        filmed = film(ch, motion, window, redrawn_seed=None)
        meta = {"character": "stick", "clip": "synthetic", "bvh_frames": list(range(FRAMES)), "bvh_step": 1,
                "variant": "plain", "crossing": []}
        shots.append(write_shot(tmp_path / f"s{k}", ch, filmed, meta))
        check_shot(shots[-1])  # the loader reads what was written; keys are the ground truth's ends
    for f in sorted((shots[0] / "gt").glob("*.png")):
        assert f.read_bytes() == (shots[1] / "gt" / f.name).read_bytes()
    first = cv2.imread(str(shots[0] / "gt" / "0000.png"))
    assert first.shape == (96, 96, 3)
    data = json.loads((shots[0] / "shot.json").read_text())
    xy = np.array([p["joints"] for p in data["poses"]])[..., :2]
    assert (xy > 0).all() and (xy < 96).all()  # the character stays in the frame
    redrawn = film(ch, motion, window, redrawn_seed=3)
    assert np.array_equal(redrawn.frames[0], filmed.frames[0])  # no warp at t = 0
    shift = np.abs(redrawn.poses[-1, :, :2] - filmed.poses[-1, :, :2]).max()
    assert 0.5 < shift <= 3.5  # the full redraw at t = 1: a few px


def test_the_held_out_plan_shares_no_character_and_clip_with_the_development_plan():
    """The split never tuned on (--plan heldout) is other motions of the same drawings: no (character, clip) pair of
    the development set, every clip and character of it drivable, and each redrawn twin has its plain shot."""
    dev = {(c, clip) for c, clip, _ in realdev_shots.PLAN}
    held = {(c, clip) for c, clip, _ in realdev_shots.HELDOUT_PLAN}
    assert not dev & held
    assert {c for c, _ in held} <= {c for c, _ in dev}  # the humanoid characters the configs drive
    for c, clip, variant in realdev_shots.HELDOUT_PLAN:
        if variant == "redrawn":
            assert (c, clip, "plain") in realdev_shots.HELDOUT_PLAN


def test_the_six_armed_plan_is_a_character_neither_other_plan_holds():
    """--plan six-arms films char5 alone, which the development and held-out plans never show; its numbered arms
    name the limbs they copy."""
    others = {c for plan in (realdev_shots.PLAN, realdev_shots.HELDOUT_PLAN) for c, _, _ in plan}
    assert {c for c, _, _ in realdev_shots.SIX_ARMS_PLAN} == {"char5"} and "char5" not in others
    assert realdev_shots.limb("right_elbow2") == realdev_shots.limb("right_elbow") == "right_arm"
    assert realdev_shots.limb("left_hand3") == "left_arm" and realdev_shots.limb("torso") == "body"
