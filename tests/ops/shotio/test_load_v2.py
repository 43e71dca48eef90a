"""Format v2 (docs/shot-format.md): any number of keys, poses by frame, ease; each bad field one clear line."""
import json

import numpy as np
import pytest

from ops.errors import ShotError
from ops.shotio.image_io import write_image
from ops.shotio.interpolate import resample_poses
from ops.shotio.load import MAX_KEYS, load_shot
from ops.shotio.versions import source_versions

from .test_load import JOINTS, PARENTS, _pose


def make_v2(tmp_path, n: int = 3, **override):
    """A valid v2 shot of n keys at frames 0, 8, 16, ...; `override` replaces fields (None deletes)."""
    img = np.ones((160, 200, 3), np.float32)
    img[40:140, 90:110] = 0.0
    for k in range(n):
        write_image(tmp_path / f"key{k}.png", img)
    frames = list(range(0, 8 * n, 8))
    data = {"format": "inbetween-shot/2", "keyframes": [f"key{k}.png" for k in range(n)], "key_frames": frames,
            "skeleton": {"joints": JOINTS, "parents": PARENTS},
            "poses": [{"frame": f, "joints": _pose(0.2 + 0.6 * k)} for k, f in enumerate(frames)],
            "t_junctions": [[] for _ in range(n)]}
    if n == 1:
        data.pop("key_frames")
        data["poses"] = [{"frame": 0, "joints": _pose(0.2)}, {"frame": 6, "joints": _pose(1.4)}]
    for k, v in override.items():
        if v is None:
            data.pop(k, None)
        else:
            data[k] = v
    (tmp_path / "shot.json").write_text(json.dumps(data))
    return tmp_path


def test_three_keys_give_their_frames_segments_and_exact_key_poses(tmp_path):
    shot = load_shot(make_v2(tmp_path))
    assert (shot.n_keys, shot.key_frames, shot.n_segments, shot.version) == (3, (0, 8, 16), 2, 2)
    np.testing.assert_array_equal(shot.times, np.arange(17))
    for k in range(3):
        np.testing.assert_array_equal(shot.key_pose(k), _pose(0.2 + 0.6 * k))  # bit for bit
    np.testing.assert_array_equal(shot.segment_frames(1), np.arange(8, 17))
    np.testing.assert_allclose(shot.segment_times(1), np.linspace(0, 1, 9))
    assert shot.ease == ("linear", "linear") and len(shot.t_junctions) == 3


def test_one_drawing_runs_to_its_last_pose(tmp_path):
    shot = load_shot(make_v2(tmp_path, n=1))
    assert (shot.n_keys, shot.key_frames, shot.n_segments, len(shot.times)) == (1, (0,), 1, 7)
    np.testing.assert_array_equal(shot.poses[6], _pose(1.4))
    np.testing.assert_array_equal(shot.segment_frames(0), np.arange(7))


def test_two_keys_interpolate_as_v1_does(tmp_path):
    """Two given poses: the C1 curve is the v1 per-bone interpolation (linear in every parameter)."""
    shot = load_shot(make_v2(tmp_path, n=2))
    a, b = np.array(_pose(0.2), float), np.array(_pose(0.8), float)
    v1 = resample_poses(np.array([0.0, 1.0]), np.stack([a, b]), np.linspace(0, 1, 9), np.array(PARENTS))
    np.testing.assert_allclose(shot.poses, v1, atol=1e-9)


def test_a_given_pose_between_keys_is_met_exactly(tmp_path):
    d = make_v2(tmp_path, n=2)
    data = json.loads((d / "shot.json").read_text())
    data["poses"].insert(1, {"frame": 3, "joints": _pose(-0.5)})
    data["ease"] = ["in-out"]
    (d / "shot.json").write_text(json.dumps(data))
    shot = load_shot(d)
    np.testing.assert_array_equal(shot.poses[3], _pose(-0.5))


@pytest.mark.parametrize("field, value, match", [
    ("key_frames", None, "key_frames: missing"),
    ("key_frames", [0, 8], "must be 3 integers"),
    ("key_frames", [1, 8, 16], r"key_frames\[0\]: the first keyframe is at frame 1"),
    ("key_frames", [0, 8, 8], r"key_frames\[2\]: frame 8 does not come after 8"),
    ("key_frames", [0, 8.0, 16], "must be 3 integers"),
    ("ease", ["fast", "linear"], r"ease\[0\]: 'fast' is not an ease"),
    ("ease", ["linear"], "ease: must be a list of 2 entries"),
    ("frames", 9, "frames: is a v1 field"),
    ("t_junctions", [[], []], "t_junctions: must be a list of 3 lists"),
    ("keyframes", [], "keyframes: must list at least one image"),
    ("keyframes", [f"key{k % 3}.png" for k in range(MAX_KEYS + 1)], f"more than {MAX_KEYS}"),
])
def test_bad_v2_fields_are_one_line(tmp_path, field, value, match):
    d = make_v2(tmp_path, **({field: value} if value is not None else {}))
    if value is None:
        data = json.loads((d / "shot.json").read_text())
        data.pop(field)
        (d / "shot.json").write_text(json.dumps(data))
    with pytest.raises(ShotError, match=match) as err:
        load_shot(d)
    assert "\n" not in str(err.value) and "fix:" in str(err.value)


def test_poses_must_cover_every_key_and_stop_at_the_last(tmp_path):
    d = make_v2(tmp_path)
    data = json.loads((d / "shot.json").read_text())
    good = list(data["poses"])
    data["poses"] = [good[0], good[2]]
    (d / "shot.json").write_text(json.dumps(data))
    with pytest.raises(ShotError, match="no pose at frame 8, keyframe 1"):
        load_shot(d)
    data["poses"] = good + [{"frame": 20, "joints": _pose(0.0)}]
    (d / "shot.json").write_text(json.dumps(data))
    with pytest.raises(ShotError, match=r"poses\[3\].frame: frame 20 comes after the last key frame 16"):
        load_shot(d)
    data["poses"] = [{"t": 0.0, "joints": _pose(0.0)}] + good[1:]
    (d / "shot.json").write_text(json.dumps(data))
    with pytest.raises(ShotError, match=r"poses\[0\]: has 't', a v1 field"):
        load_shot(d)


def test_ground_truth_may_be_any_subset_but_not_past_the_end(tmp_path):
    d = make_v2(tmp_path, ground_truth="gt")
    (d / "gt").mkdir()
    write_image(d / "gt" / "0005.png", np.ones((160, 200, 3), np.float32))
    assert load_shot(d).ground_truth is not None
    write_image(d / "gt" / "0017.png", np.ones((160, 200, 3), np.float32))
    with pytest.raises(ShotError, match="0017.png is past the last output frame 16"):
        load_shot(d)


def test_sources_change_exactly_with_what_they_cover(tmp_path):
    """A T-junction edit changes only its key's source; key 2's pose changes segment 1's motion and, through the
    curve's tangent at key 1, segment 0's."""
    d = make_v2(tmp_path)
    v0 = source_versions(load_shot(d))
    data = json.loads((d / "shot.json").read_text())
    data["t_junctions"][1] = [[100, 60]]
    (d / "shot.json").write_text(json.dumps(data))
    v1 = source_versions(load_shot(d))
    assert {k for k in v0 if v0[k] != v1[k]} == {"key1/t_junctions"}
    data["poses"][2]["joints"] = _pose(2.0)  # key 2's pose: segment 1 and, through key 1's tangent, segment 0
    (d / "shot.json").write_text(json.dumps(data))
    v2 = source_versions(load_shot(d))
    assert {k for k in v1 if v1[k] != v2[k]} == {"key2/pose", "seg0/motion", "seg1/motion"}
