"""The held-out in-betweening shots of the 3D generator: deterministic, loadable, keys = ground truth ends, joints
on the drawing, bodies moved rigidly."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from benchmarks.heldout_shots import check_shot
from data_samples.generator.bodies3d import make_body
from data_samples.generator.shots3d import PLAN, SHOT_FRAMES, axis_rotation, make_shot3d, posed, write_shot3d
from ops.shotio.load import ground_truth_files, load_shot

SIZE = (128, 128)
INDICES = (0, 3)  # a person reaching across the body (ink), a held-out creature sweeping its tail


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    root = tmp_path_factory.mktemp("heldout")
    shots = {i: make_shot3d(i, SIZE) for i in INDICES}
    return shots, {i: write_shot3d(s, root) for i, s in shots.items()}


def test_the_plan_mixes_families_and_holds_out_creature_and_crayon():
    assert len({f for f, _, _ in PLAN}) == 5 and len({s for _, s, _ in PLAN}) == 7
    assert sum(f == "creature" or s == "crayon" for f, s, _ in PLAN) >= 2


def test_shots_are_deterministic(written):
    _, dirs = written
    again = make_shot3d(INDICES[0], SIZE)
    data = json.loads((dirs[INDICES[0]] / "shot.json").read_text())
    for i, f in enumerate(ground_truth_files(dirs[INDICES[0]] / "gt")):
        assert np.array_equal(cv2.imread(str(f), cv2.IMREAD_COLOR)[..., ::-1], again.frames[i])
    np.testing.assert_allclose(np.array([p["joints"] for p in data["poses"]]), again.poses, atol=0.006)


def test_shots_load_with_keys_equal_to_the_ground_truth_ends(written):
    _, dirs = written
    for d in dirs.values():
        check_shot(d)  # the loader's view: frames, poses, gt count, key bytes = gt ends
        shot = load_shot(d)
        assert len(shot.times) == SHOT_FRAMES and shot.size == SIZE
        gt = ground_truth_files(shot.ground_truth)
        for key, f in zip(shot.keyframes, (gt[0], gt[-1])):
            assert np.array_equal(cv2.imread(str(key)), cv2.imread(str(f)))
        assert not np.array_equal(cv2.imread(str(gt[0])), cv2.imread(str(gt[-1])))  # the character moved


def test_joints_project_onto_the_drawn_character(written):
    """Every joint of every frame lies inside the image, on the character's coverage (within 3 px)."""
    shots, dirs = written
    for i, d in dirs.items():
        data = json.loads((d / "shot.json").read_text())
        h, w = SIZE
        for k, p in enumerate(data["poses"]):
            xy = np.array(p["joints"])[:, :2]
            assert (xy >= 0).all() and (xy[:, 0] < w).all() and (xy[:, 1] < h).all(), (d.name, k)
            near = cv2.dilate((shots[i].coverage[k] >= 0.5).astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
            r, c = np.round(xy[:, 1]).astype(int), np.round(xy[:, 0]).astype(int)
            off = [data["skeleton"]["joints"][j] for j in np.nonzero(~near[r, c])[0]]
            assert not off, (d.name, k, off)


def test_a_reach_brings_the_arm_across_the_body(written):
    shot = written[0][0]
    arm = {p for p in shot.crossings[1] if "elbow" in p or "hand" in p} - set(shot.crossings[0])
    assert arm, shot.crossings


def test_posing_is_rigid_per_bone():
    """Turned bones keep their 3D length, and every solid keeps its distance to its bone's parent joint."""
    body = make_body(np.random.default_rng(5), "creature")
    rng = np.random.default_rng(1)
    turns = {c: axis_rotation(rng.normal(size=3), float(rng.uniform(-60, 60))) for c in range(1, len(body.joints))}
    moved = posed(body, turns)
    par = np.array(body.parents)
    kids = np.nonzero(par >= 0)[0]
    np.testing.assert_allclose(np.linalg.norm(moved.pose[kids] - moved.pose[par[kids]], axis=1),
                               np.linalg.norm(body.pose[kids] - body.pose[par[kids]], axis=1), atol=1e-9)
    for a, b in zip(body.solids, moved.solids):
        p = body.parents[a.bone]
        before = np.linalg.norm(a.centre - body.pose[p])
        assert abs(np.linalg.norm(b.centre - moved.pose[p]) - before) < 1e-9
        np.testing.assert_array_equal(a.radii, b.radii)
    assert np.abs(moved.pose - body.pose).max() > 1.0
