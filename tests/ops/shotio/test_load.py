"""Shot loading: every bad input gives the one-line ShotError; interpolation is per bone."""
import json
import math

import numpy as np
import pytest

from ops.errors import ShotError
from ops.shotio.image_io import write_image
from ops.shotio.interpolate import interpolate_pose
from ops.shotio.load import load_shot
from ops.shotio.versions import source_versions

JOINTS = ["hips", "spine", "neck", "r_shoulder", "r_elbow", "r_hand"]
PARENTS = [-1, 0, 1, 1, 3, 4]


def _pose(angle: float) -> list:
    """A chain with the arm rotated by `angle` about the shoulder."""
    pts = [[100, 150, 0], [100, 110, 0], [100, 80, 0], [110, 85, 0]]
    sx, sy = 110, 85
    for r in (25, 50):
        pts.append([sx + r * math.cos(angle), sy + r * math.sin(angle), -1])
    return pts


def make_shot(tmp_path, **override):
    """A valid minimal shot directory; `override` replaces shot.json fields (None deletes)."""
    img = np.ones((160, 200, 3), np.float32)
    img[40:140, 90:110] = 0.0
    write_image(tmp_path / "key0.png", img)
    write_image(tmp_path / "key1.png", img)
    data = {
        "format": "inbetween-shot/1",
        "keyframes": ["key0.png", "key1.png"],
        "skeleton": {"joints": JOINTS, "parents": PARENTS},
        "poses": [{"t": 0.0, "joints": _pose(0.2)}, {"t": 1.0, "joints": _pose(1.4)}],
        "frames": 5,
        "t_junctions": [[[100, 100]], []],
    }
    for k, v in override.items():
        if v is None:
            data.pop(k, None)
        else:
            data[k] = v
    (tmp_path / "shot.json").write_text(json.dumps(data))
    return tmp_path


def test_valid_shot_interpolates_frames(tmp_path):
    shot = load_shot(make_shot(tmp_path))
    assert shot.poses.shape == (5, 6, 3)
    np.testing.assert_allclose(shot.times, np.linspace(0, 1, 5))
    np.testing.assert_allclose(shot.poses[0], _pose(0.2))
    np.testing.assert_allclose(shot.poses[-1], _pose(1.4), atol=1e-9)


def test_interpolation_rotates_bones_and_keeps_lengths():
    a, b = np.array(_pose(0.2), float), np.array(_pose(1.4), float)
    mid = interpolate_pose(a, b, 0.5, np.array(PARENTS))
    # bone lengths stay (a linear blend of joint positions would shorten the arm)
    for c in (4, 5):
        p = PARENTS[c]
        assert np.linalg.norm(mid[c, :2] - mid[p, :2]) == pytest.approx(25.0, abs=1e-9)
    ang = math.atan2(mid[5, 1] - mid[3, 1], mid[5, 0] - mid[3, 0])
    assert ang == pytest.approx(0.8, abs=1e-9)
    lin = 0.5 * (a + b)
    assert np.linalg.norm(lin[5, :2] - lin[3, :2]) < 49.0  # what the linear mistake would give


def test_shortest_arc():
    a, b = np.array(_pose(math.pi - 0.1), float), np.array(_pose(-math.pi + 0.1), float)
    mid = interpolate_pose(a, b, 0.5, np.array(PARENTS))
    ang = math.atan2(mid[5, 1] - mid[3, 1], mid[5, 0] - mid[3, 0])
    assert abs(abs(ang) - math.pi) < 1e-9  # through pi, not through 0


BAD = [
    ({"format": "other"}, "format"),
    ({"keyframes": ["key0.png"]}, "keyframes"),
    ({"keyframes": ["key0.png", "missing.png"]}, "keyframes[1]"),
    ({"keyframes": ["key0.png", "../escape.png"]}, "escapes"),
    ({"poses": [{"t": 0.0, "joints": _pose(0.2)[:5]}, {"t": 1.0, "joints": _pose(1.4)}]}, "poses[0].joints"),
    ({"poses": [{"t": 0.0, "joints": _pose(0.2)}, {"t": 0.5, "joints": _pose(0.2)}, {"t": 0.5, "joints": _pose(0.2)}, {"t": 1.0, "joints": _pose(1.4)}]}, "poses[2].t"),
    ({"poses": [{"t": 0.1, "joints": _pose(0.2)}, {"t": 1.0, "joints": _pose(1.4)}]}, "poses[0].t"),
    ({"poses": [{"t": 0.0, "joints": _pose(0.2)}, {"t": 0.9, "joints": _pose(1.4)}]}, "poses[1].t"),
    ({"skeleton": {"joints": JOINTS, "parents": [-1, -1, 1, 1, 3, 4]}}, "2 roots"),
    ({"skeleton": {"joints": JOINTS, "parents": [-1, 2, 1, 1, 3, 4]}}, "cycle"),
    ({"skeleton": {"joints": JOINTS[:5] + ["hips"], "parents": PARENTS}}, "duplicate"),
    ({"poses": [{"t": 0.0, "joints": [[float("nan"), 0, 0]] + _pose(0.2)[1:]}, {"t": 1.0, "joints": _pose(1.4)}]}, "NaN"),
    ({"t_junctions": [[[500, 10]], []]}, "t_junctions[0][0]"),
    ({"frames": 1}, "frames"),
]


@pytest.mark.parametrize("override,needle", BAD)
def test_bad_input_one_line_error(tmp_path, override, needle):
    # NaN is not valid JSON for json.dumps by default, but Python writes it; the loader must catch it
    shot_dir = make_shot(tmp_path, **override)
    with pytest.raises(ShotError) as e:
        load_shot(shot_dir)
    msg = str(e.value)
    assert "\n" not in msg and needle in msg and "shot.json" in msg and "fix:" in msg


def test_different_sizes(tmp_path):
    shot_dir = make_shot(tmp_path)
    write_image(shot_dir / "key1.png", np.ones((100, 100, 3), np.float32))
    with pytest.raises(ShotError, match="keyframes.*same size"):
        load_shot(shot_dir)


def test_unreadable_image(tmp_path):
    shot_dir = make_shot(tmp_path)
    (shot_dir / "key1.png").write_bytes(b"not an image")
    with pytest.raises(ShotError, match=r"keyframes\[1\]"):
        load_shot(shot_dir)


def test_huge_image_refused_from_header(tmp_path):
    import OpenImageIO as oiio

    shot_dir = make_shot(tmp_path)
    spec = oiio.ImageSpec(9000, 16, 1, oiio.UINT8)
    out = oiio.ImageOutput.create(str(shot_dir / "key1.png"))
    out.open(str(shot_dir / "key1.png"), spec)
    out.write_image(np.zeros((16, 9000, 1), np.uint8))
    out.close()
    with pytest.raises(ShotError, match="larger than 8192"):
        load_shot(shot_dir)


def test_missing_shot_json(tmp_path):
    with pytest.raises(ShotError, match="shot.json"):
        load_shot(tmp_path)


def test_source_versions_cover_exactly_their_fields(tmp_path):
    shot_dir = make_shot(tmp_path)
    v0 = source_versions(load_shot(shot_dir))
    data = json.loads((shot_dir / "shot.json").read_text())
    data["t_junctions"][1] = [[100, 60]]
    (shot_dir / "shot.json").write_text(json.dumps(data))
    v1 = source_versions(load_shot(shot_dir))
    changed = {k for k in v0 if v0[k] != v1[k]}
    assert changed == {"key1/t_junctions"}
    # an in-between pose edit changes only the motion
    data["frames"] = None
    data.pop("frames")
    data["poses"].insert(1, {"t": 0.5, "joints": _pose(0.5)})
    (shot_dir / "shot.json").write_text(json.dumps(data))
    v2 = source_versions(load_shot(shot_dir))
    assert {k for k in v1 if v1[k] != v2[k]} == {"seg0/motion"}
