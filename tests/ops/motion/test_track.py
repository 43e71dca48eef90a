"""Points tracked through a synthetic video (moving textured dots encoded with imageio-ffmpeg)."""
import json

import cv2
import imageio_ffmpeg
import numpy as np
import pytest

from ops.errors import ShotError
from ops.motion.fit import bone_geometry, fit_clip, wrap
from ops.motion.track import read_points, read_video, similarity, track, tracks_to_clip

SIZE = (128, 160)  # H, W


def dot(img, xy, seed):
    """A textured 9x9 patch (LK needs texture) centred at xy."""
    rng = np.random.default_rng(seed)
    patch = rng.integers(0, 255, (9, 9)).astype(np.uint8)
    patch = cv2.resize(patch, (18, 18), interpolation=cv2.INTER_NEAREST)
    x, y = int(round(xy[0])) - 9, int(round(xy[1])) - 9
    img[y:y + 18, x:x + 18] = patch[..., None]


def write_video(path, paths, hide=None):
    """paths: {name: (F, 2)} positions; hide: (name, frame) from which that dot disappears."""
    F = len(next(iter(paths.values())))
    writer = imageio_ffmpeg.write_frames(str(path), (SIZE[1], SIZE[0]), fps=24, quality=10, macro_block_size=16,
                                         output_params=["-g", "1"])
    writer.send(None)
    for f in range(F):
        img = np.full(SIZE + (3,), 200, np.uint8)
        for i, (name, p) in enumerate(paths.items()):
            if hide and name == hide[0] and f >= hide[1]:
                continue
            dot(img, p[f], i)
        writer.send(np.ascontiguousarray(img))
    writer.close()


def test_tracks_follow_the_dots_and_drive_the_arm(tmp_path):
    F = 24
    t = np.arange(F) / F * np.pi / 2
    centre = np.array([80.0, 64.0])
    direction = np.stack([np.cos(t), np.sin(t)], 1)
    paths = {"shoulder": np.repeat(centre[None], F, 0), "elbow": centre + 25 * direction, "hand": centre + 45 * direction}
    video = tmp_path / "clip.mp4"
    write_video(video, paths)
    frames, fps = read_video(video)
    assert frames.shape == (F,) + SIZE and fps == 24
    got = track(frames, {n: p[0] for n, p in paths.items()}, video)
    for n in paths:
        assert np.abs(got[n] - paths[n]).max() < 1.5, n  # the dots are drawn at whole pixels
    # an arm drawn twice as large elsewhere: its bones turn by the dots' quarter turn
    joints, parents = ("shoulder", "elbow", "hand"), np.array([-1, 0, 1])
    key = np.array([[300.0, 200.0, 0.0], [350.0, 200.0, 0.0], [390.0, 200.0, 0.0]])
    poses = fit_clip(tracks_to_clip(got, joints, parents, key), parents, np.array([0]), key[None])
    assert np.abs(poses[0] - key).max() < 1e-9
    turn = wrap(bone_geometry(poses[-1], parents)[0][2] - bone_geometry(poses[0], parents)[0][2])
    assert abs(turn - t[-1]) < 0.03


def test_a_lost_point_names_itself_and_the_frame(tmp_path):
    F = 16
    paths = {"a": np.c_[np.linspace(40, 60, F), np.full(F, 60.0)], "b": np.c_[np.full(F, 110.0), np.linspace(40, 50, F)]}
    video = tmp_path / "clip.mp4"
    write_video(video, paths, hide=("b", 9))
    frames, _ = read_video(video)
    with pytest.raises(ShotError) as e:
        track(frames, {n: p[0] for n, p in paths.items()}, video)
    assert e.value.field == "points.b" and "frame 9" in str(e.value)


def test_bad_video_and_points_are_one_line(tmp_path):
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"this is not a video" * 10)
    with pytest.raises(ShotError) as e:
        read_video(junk)
    assert "cannot be decoded" in str(e.value) and "\n" not in str(e.value)
    pts = tmp_path / "points.json"
    pts.write_text(json.dumps({"hand": [500, 10]}))
    with pytest.raises(ShotError) as e:
        read_points(pts, ("hand",), SIZE)
    assert e.value.field == "hand" and "outside" in str(e.value)
    pts.write_text(json.dumps({"tail": [5, 10]}))
    with pytest.raises(ShotError) as e:
        read_points(pts, ("hand",), SIZE)
    assert "not a joint" in str(e.value)


def test_similarity_recovers_a_known_transform():
    rng = np.random.default_rng(0)
    src = rng.normal(0, 10, (6, 2))
    c, s = np.cos(0.7), np.sin(0.7)
    dst = 1.8 * src @ np.array([[c, -s], [s, c]]).T + [3.0, -4.0]
    theta, scale, t = similarity(src, dst)
    assert np.isclose(theta, 0.7) and np.isclose(scale, 1.8) and np.allclose(t, [3, -4])
