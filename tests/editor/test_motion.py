"""The Pose view's API on a v2 shot of several keys: the motion at output frames is the loader's, and a re-pose
names a key of a segment."""
from __future__ import annotations

import numpy as np

from ops.shotio.load import load_shot
from tests.assets.conftest import SAMPLES, scaled_copy

from .conftest import call_json


def test_motion_of_a_v2_shot_is_the_loaders_at_whole_frames(serve, tmp_path):
    shot_dir = scaled_copy(SAMPLES / "seq_dino_step", tmp_path / "shots" / "seq_dino_step", 0.5)  # eases
    s = serve(shot_dir)
    shot = load_shot(shot_dir)
    status, got = call_json(s.url + "/api/motion", "POST", {"times": [3, 6.4, 17, 99]})
    assert status == 200 and got["times"] == [3, 6, 17, 20] and got["key_frames"] == [0, 6, 14, 20]
    np.testing.assert_allclose(got["poses"], shot.poses[[3, 6, 17, 20]], atol=1e-4)
    edited = call_json(s.url + "/api/shot")[1]
    edited["poses"][1]["joints"][0][0] += 5.0  # the object being edited, not the saved one
    got = call_json(s.url + "/api/motion", "POST", {"shot": edited, "times": [6]})[1]
    assert abs(got["poses"][0][0][0] - shot.poses[6][0][0] - 5.0) < 1e-3
    status, _ = call_json(s.url + "/api/motion", "POST", {})
    assert status == 200
    del edited["key_frames"]
    status, err = call_json(s.url + "/api/motion", "POST", {"shot": edited})
    assert status == 400 and err["field"] == "key_frames"


def test_repose_names_a_key_of_a_segment(serve, tmp_path):
    shot_dir = scaled_copy(SAMPLES / "seq_arm_cross", tmp_path / "shots" / "seq_arm_cross", 0.5)
    s = serve(shot_dir)
    joints = call_json(s.url + "/api/shot")[1]["poses"][0]["joints"]
    for body, field in (({"seg": 2, "k": 2}, "seg"), ({"seg": 1, "k": 0}, "k"), ({"seg": "one"}, "seg")):
        status, err = call_json(s.url + "/api/repose", "POST", {**body, "joints": joints})
        assert status == 400 and err["field"] == field, (body, err)
    status, err = call_json(s.url + "/api/repose", "POST", {"seg": 1, "k": 2, "t": 0.5, "joints": joints})
    assert status == 409 and "seg1/key2/textured_template" in err["error"]  # no run yet
