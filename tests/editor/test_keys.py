"""The timeline's API: add a key (an uploaded image at a frame), remove one, move one in time; refusals write
nothing, a v1 shot becomes v2 on its first such edit, and every saved shot loads with ops.shotio.load."""
from __future__ import annotations

import json
from urllib.parse import urlencode

import cv2
import numpy as np
import pytest

from ops.shotio.load import load_shot
from tests.assets.conftest import SAMPLES, scaled_copy

from .conftest import call, call_json


@pytest.fixture
def seq_shot(tmp_path):
    """seq_arm_cross at half size: three keys at frames 0, 8, 16 (no ease), ground truth frames."""
    return scaled_copy(SAMPLES / "seq_arm_cross", tmp_path / "shots" / "seq_arm_cross", 0.5)


def _add(url: str, shot_dir, frame, name="new.png", body: bytes | None = None):
    body = (shot_dir / "key1.png").read_bytes() if body is None else body
    query = urlencode({k: v for k, v in (("frame", frame), ("name", name)) if v is not None})
    status, headers, raw = call(f"{url}/api/keys?{query}", "POST", body, {"Content-Type": "application/octet-stream"})
    return status, json.loads(raw), headers


def _unchanged(shot_dir, before: bytes, files: set[str]) -> None:
    assert (shot_dir / "shot.json").read_bytes() == before
    assert {p.name for p in shot_dir.iterdir()} == files


def test_info_lists_the_graph_of_every_key(serve, seq_shot):
    s = serve(seq_shot)
    info = call_json(s.url + "/api/info")[1]
    assert info["keys"] == 3 and "key2/masks" in info["stages"] and "seg1/frames" in info["stages"]
    assert "key3/masks" not in info["stages"]
    assert call(s.url + "/api/keyframes/2.png")[0] == 200 and call(s.url + "/api/keyframes/3.png")[0] == 400


def test_add_key_copies_the_image_and_inserts_an_interpolated_pose(serve, seq_shot):
    s = serve(seq_shot)
    motion = load_shot(seq_shot).poses  # (17, J, 3): the pose at each output frame before the edit
    status, got, headers = _add(s.url, seq_shot, 4, name="my drawing.png")
    assert status == 200 and got["k"] == 1 and got["keys"] == 4 and got["name"] == "my_drawing.png"
    assert headers["etag"] == call(s.url + "/api/shot")[1]["etag"]
    assert (seq_shot / "my_drawing.png").read_bytes() == (seq_shot / "key1.png").read_bytes()
    data = json.loads((seq_shot / "shot.json").read_text())
    assert data["keyframes"] == ["key0.png", "my_drawing.png", "key1.png", "key2.png"]
    assert data["key_frames"] == [0, 4, 8, 16]
    assert data["t_junctions"][1] == [] and len(data["t_junctions"]) == 4 and data["t_junctions"][2]
    pose = next(p for p in data["poses"] if p["frame"] == 4)
    np.testing.assert_allclose(pose["joints"], motion[4], atol=0.01)
    shot = load_shot(seq_shot)
    assert shot.key_frames == (0, 4, 8, 16) and len(shot.times) == 17
    np.testing.assert_allclose(shot.poses[8], motion[8])  # the other keys' poses are untouched
    assert call_json(s.url + "/api/status")[1]["reason"] == "timeline"
    # the same name again gets a free one; a key after the last adds a segment
    status, got, _ = _add(s.url, seq_shot, 20, name="my drawing.png")
    assert status == 200 and got["k"] == 4 and got["name"] == "my_drawing-2.png"
    assert load_shot(seq_shot).key_frames == (0, 4, 8, 16, 20)
    assert next(p for p in json.loads((seq_shot / "shot.json").read_text())["poses"] if p["frame"] == 20)["joints"] \
        == next(p for p in data["poses"] if p["frame"] == 16)["joints"]  # past the end: the nearest pose


def test_add_key_refusals_write_nothing(serve, seq_shot):
    s = serve(seq_shot)
    before, files = (seq_shot / "shot.json").read_bytes(), {p.name for p in seq_shot.iterdir()}
    small = cv2.imencode(".png", np.full((40, 50, 3), 255, np.uint8))[1].tobytes()
    for frame, name, body, field, problem in (
            (8, "a.png", None, "key_frames", "key1's already"),
            (0, "a.png", None, "key_frames", "key0's already"),
            (None, "a.png", None, "frame", "is missing"),
            ("x", "a.png", None, "frame", "not an integer"),
            (5, None, None, "name", "is missing"),
            (5, "a.txt", None, "keyframes", "not an image file name"),
            (5, "a.png", small, "keyframes", "50x40"),
            (5, "a.png", b"not an image", "keyframes[1]", "")):
        status, err, _ = _add(s.url, seq_shot, frame, name, body)
        assert status == 400 and err["field"] == field and problem in err["error"], (frame, name, err)
        assert "\n" not in err["error"] and "fix: " in err["error"]
        _unchanged(seq_shot, before, files)
    assert call_json(s.url + "/api/status")[1]["seq"] == 0  # nothing queued


def test_remove_key_keeps_the_motion_and_refuses_the_last_key(serve, seq_shot):
    s = serve(seq_shot)
    status, got = call_json(s.url + "/api/keys/1", "DELETE")
    assert status == 200 and got["keys"] == 2 and got["dropped"] == []
    data = json.loads((seq_shot / "shot.json").read_text())
    assert data["keyframes"] == ["key0.png", "key2.png"] and data["key_frames"] == [0, 16]
    assert [p["frame"] for p in data["poses"]] == [0, 8, 16]  # key1's pose stays, as an in-between pose
    assert len(data["t_junctions"]) == 2 and data["t_junctions"][1] == []
    assert load_shot(seq_shot).key_frames == (0, 16)
    # key0 goes: key2 becomes the first key, every frame moves back, the ground truth no longer lines up
    status, got = call_json(s.url + "/api/keys/0", "DELETE")
    assert status == 200 and got["keys"] == 1 and got["dropped"] == ["ground_truth"]
    data = json.loads((seq_shot / "shot.json").read_text())
    assert data["key_frames"] == [0] and [p["frame"] for p in data["poses"]] == [0] and "ground_truth" not in data
    load_shot(seq_shot)
    before = (seq_shot / "shot.json").read_bytes()
    status, err = call_json(s.url + "/api/keys/0", "DELETE")
    assert status == 400 and err["field"] == "keyframes" and "one key" in err["error"]
    assert call_json(s.url + "/api/keys/1", "DELETE")[0] == 400  # no such key
    assert (seq_shot / "shot.json").read_bytes() == before


def test_move_key_keeps_frames_increasing_and_moves_the_pose(serve, seq_shot):
    s = serve(seq_shot)
    data = json.loads((seq_shot / "shot.json").read_text())
    key1_pose = data["poses"][1]["joints"]
    before = (seq_shot / "shot.json").read_bytes()
    for k, body, field, problem in ((1, {"frame": 16}, "key_frames[1]", "not between key0 (frame 0) and key2"),
                                    (1, {"frame": 0}, "key_frames[1]", "not between"),
                                    (0, {"frame": 3}, "key_frames[0]", "key0"),
                                    (1, {"frame": "x"}, "frame", "not a frame"),
                                    (1, {"frame": 2.5}, "frame", "not a frame"),
                                    (1, {}, "frame", "not a frame"),
                                    (3, {"frame": 20}, "k", "does not exist")):
        status, err = call_json(f"{s.url}/api/keys/{k}/move", "POST", body)
        assert status == 400 and err["field"] == field and problem in err["error"], (k, body, err)
        assert (seq_shot / "shot.json").read_bytes() == before
    status, got = call_json(s.url + "/api/keys/1/move", "POST", {"frame": 11})
    assert status == 200 and got["k"] == 1 and got["dropped"] == ["ground_truth"]
    data = json.loads((seq_shot / "shot.json").read_text())
    assert data["key_frames"] == [0, 11, 16]
    assert next(p for p in data["poses"] if p["frame"] == 11)["joints"] == key1_pose
    assert load_shot(seq_shot).key_frames == (0, 11, 16)
    assert call_json(s.url + "/api/keys/2/move", "POST", {"frame": 30})[0] == 200  # the last key: later is fine
    assert load_shot(seq_shot).key_frames == (0, 11, 30)


def test_in_between_poses_and_eases_follow_structural_edits(serve, tmp_path):
    shot_dir = scaled_copy(SAMPLES / "seq_dino_step", tmp_path / "shots" / "seq_dino_step", 0.5)
    data = json.loads((shot_dir / "shot.json").read_text())
    data["poses"].insert(2, {"frame": 10, "joints": data["poses"][1]["joints"]})  # an in-between pose in seg1
    (shot_dir / "shot.json").write_text(json.dumps(data))
    s = serve(shot_dir)
    assert call_json(s.url + "/api/keys/1/move", "POST", {"frame": 2})[0] == 200  # seg1 stretches: 10 -> 8
    data = json.loads((shot_dir / "shot.json").read_text())
    assert [p["frame"] for p in data["poses"]] == [0, 2, 8, 14, 20]
    assert _add(s.url, shot_dir, 17)[0] == 200  # splits seg2's slow in: linear, then in
    assert json.loads((shot_dir / "shot.json").read_text())["ease"] == ["out", "linear", "linear", "in"]
    assert call_json(s.url + "/api/keys/1", "DELETE")[0] == 200  # joins seg0's slow out with seg1
    got = json.loads((shot_dir / "shot.json").read_text())
    assert got["ease"] == ["out", "linear", "in"] and got["key_frames"] == [0, 14, 17, 20]
    assert load_shot(shot_dir).ease == ("out", "linear", "in")


def test_a_v1_shot_becomes_v2_on_its_first_structural_edit(serve, small_shot):
    s = serve(small_shot)
    v1 = load_shot(small_shot)  # nine poses, one output frame each
    status, got, _ = _add(s.url, small_shot, 12)
    assert status == 200 and got["format"] == "inbetween-shot/2" and got["k"] == 2
    data = json.loads((small_shot / "shot.json").read_text())
    assert data["format"] == "inbetween-shot/2" and data["key_frames"] == [0, 8, 12] and "frames" not in data
    assert [p["frame"] for p in data["poses"]] == list(range(9)) + [12] and all("t" not in p for p in data["poses"])
    v2 = load_shot(small_shot)
    np.testing.assert_allclose(v2.poses[:9], v1.poses, atol=1e-9)  # every v1 output frame is a given pose
    assert v2.t_junctions[1].shape == (2, 2) and v2.t_junctions[2].shape == (0, 2)
    assert json.loads((small_shot / "shot.json.bak").read_text())["format"] == "inbetween-shot/1"
    info = call_json(s.url + "/api/info")[1]
    assert info["keys"] == 3 and "seg1/frames" in info["stages"]


def test_a_v1_shot_with_frames_keeps_its_timing(serve, small_shot):
    data = json.loads((small_shot / "shot.json").read_text())
    data["poses"] = [data["poses"][0], data["poses"][4], data["poses"][-1]]
    data["frames"] = 5
    (small_shot / "shot.json").write_text(json.dumps(data))
    s = serve(small_shot)
    assert call_json(s.url + "/api/keys/1/move", "POST", {"frame": 6})[0] == 200
    got = json.loads((small_shot / "shot.json").read_text())
    assert got["key_frames"] == [0, 6] and [p["frame"] for p in got["poses"]] == [0, 3, 6]
    assert len(load_shot(small_shot).times) == 7
