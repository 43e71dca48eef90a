"""The committed sample shots: valid shot.json, consistent images and ground truth, regenerable bit for bit."""
from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from ops.shotio.image_io import read_image

ROOT = Path(__file__).resolve().parents[2] / "data_samples"
# the two-key v1 shots of shots.py; the format-2 sequences and one-drawing shots (sequences.py) have their own
# tests in tests/data_samples/test_shots.py
SHOT_DIRS = sorted(p.parent for p in ROOT.glob("*/shot.json")
                   if json.loads(p.read_text()).get("format") == "inbetween-shot/1")
NAMES = [d.name for d in SHOT_DIRS]
INK_ON_WHITE = ["no_occlusion", "arm_cross", "legs_cross", "tail", "manual_masks", "two_poses"]  # the first six


def _generator():
    """Import data_samples/generate.py as a module (it is a script, not a package)."""
    if "samples_generate" not in sys.modules:
        spec = importlib.util.spec_from_file_location("samples_generate", ROOT / "generate.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules["samples_generate"] = mod  # dataclasses look their module up while the class is built
        spec.loader.exec_module(mod)
    return sys.modules["samples_generate"]


def _load(d: Path) -> dict:
    """Parsed shot.json of one shot directory."""
    return json.loads((d / "shot.json").read_text())


def _gt_frames(d: Path, data: dict) -> list[Path]:
    """Ground-truth frame paths 0000.png (or .jpg, like the keyframes) ... in order."""
    return sorted((d / data["ground_truth"]).glob("*" + Path(data["keyframes"][0]).suffix))


def _edges(img: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels where the colour changes by > 0.12 within a 3x3 neighbourhood (lines, wash edges)."""
    spread = ndimage.maximum_filter(img, size=(3, 3, 1)) - ndimage.minimum_filter(img, size=(3, 3, 1))
    return spread.max(axis=2) > 0.12


def test_all_required_shots_present():
    assert {"no_occlusion", "arm_cross", "legs_cross", "tail", "manual_masks", "two_poses"} <= set(NAMES)
    total = sum(f.stat().st_size for f in ROOT.rglob("*") if f.is_file())
    assert total < 5e6, f"data_samples is {total / 1e6:.1f} MB"  # sixteen shots (twelve v1, four v2): 4.1 MB


@pytest.mark.parametrize("d", SHOT_DIRS, ids=NAMES)
def test_shot_json_fields(d):
    data = _load(d)
    assert data["format"] == "inbetween-shot/1"
    ext = ".jpg" if d.name == "scan_jpeg" else ".png"  # a photographed drawing comes as JPEG
    assert data["keyframes"] == ["key0" + ext, "key1" + ext]
    joints, parents = data["skeleton"]["joints"], data["skeleton"]["parents"]
    assert len(set(joints)) == len(joints) == len(parents)
    assert parents.count(-1) == 1 and all(-1 <= p < len(joints) for p in parents)
    t = [p["t"] for p in data["poses"]]
    assert t[0] == 0.0 and t[-1] == 1.0 and all(b > a for a, b in zip(t, t[1:]))
    for pose in data["poses"]:
        assert len(pose["joints"]) == len(joints)
        assert all(len(j) == 3 and all(math.isfinite(v) for v in j) for j in pose["joints"])
    assert len(data["t_junctions"]) == 2
    n_out = data.get("frames", len(data["poses"]))
    if "frames" in data:  # only the two key poses are given
        assert len(data["poses"]) == 2
    else:
        np.testing.assert_allclose(t, np.linspace(0, 1, len(t)))  # evenly spaced output times
    assert len(_gt_frames(d, data)) == n_out == 9


@pytest.mark.parametrize("d", SHOT_DIRS, ids=NAMES)
def test_keyframes_match_ground_truth_ends(d):
    data = _load(d)
    k0, k1 = (read_image(d / k) for k in data["keyframes"])
    gt = _gt_frames(d, data)
    assert k0.shape == k1.shape and k0.shape[2] == 3
    assert k0.shape[:2] == ((384, 384) if d.name == "arm_cross" else (256, 256))
    assert (d / data["keyframes"][0]).read_bytes() == gt[0].read_bytes()
    assert (d / data["keyframes"][1]).read_bytes() == gt[-1].read_bytes()
    assert not np.array_equal(k0, k1)
    for k, img in enumerate((k0, k1)):
        if d.name in INK_ON_WHITE:  # ink on white paper
            assert np.all(img[0] == 1.0) and np.all(img[-1] == 1.0) and np.all(img[:, 0] == 1.0)
            assert (img < 0.5).any()
        fg = read_image(d / "gt_fg" / f"key{k}.png")[..., 0] > 0.5  # the character well inside the frame
        rows, cols = np.nonzero(fg.any(axis=1))[0], np.nonzero(fg.any(axis=0))[0]
        assert fg.sum() > 500 and rows.min() > 2 and rows.max() < img.shape[0] - 3
        assert cols.min() > 2 and cols.max() < img.shape[1] - 3


@pytest.mark.parametrize("d", SHOT_DIRS, ids=NAMES)
def test_t_junctions_lie_on_ink(d):
    """On a drawn line (ink shots: a dark pixel) or, without outlines, on a colour edge, within 3 px."""
    data = _load(d)
    for k, pts in enumerate(data["t_junctions"]):
        img = read_image(d / data["keyframes"][k])
        drawn = img.mean(axis=2) < 0.5 if d.name in INK_ON_WHITE else _edges(img)
        dist = ndimage.distance_transform_edt(~drawn)  # px to the nearest drawn pixel
        for x, y in pts:
            assert dist[int(round(y)), int(round(x))] <= 3.0, (k, x, y)


def test_occlusion_structure_per_shot():
    """What each shot is meant to show: where occlusions and T-junctions are, and which masks are listed."""
    tj = {n: [len(p) for p in _load(ROOT / n)["t_junctions"]] for n in NAMES}
    occ = {n: sorted(e["file"] for e in json.loads((ROOT / n / "gt_occ" / "index.json").read_text())) for n in NAMES}
    assert tj["no_occlusion"] == [0, 0] and occ["no_occlusion"] == []
    assert tj["arm_cross"] == [0, 2] and occ["arm_cross"] == ["key1_occ0.png"]
    assert tj["manual_masks"] == [2, 0] and occ["manual_masks"] == ["key0_occ0.png"]
    for n in ("legs_cross", "tail", "two_poses"):
        assert tj[n][0] == 0 and tj[n][1] >= 2 and tj[n][1] % 2 == 0
        assert all(f.startswith("key1_") for f in occ[n]) and occ[n]
    assert tj["lamp"] == [2, 0] and occ["lamp"] == ["key0_occ0.png"]  # the shade lies on the base in key0 only
    for n in ("watercolour", "flat_colour", "scan_jpeg", "hand_on_hip", "curled_tail"):
        assert min(tj[n]) >= 2 and any(f.startswith("key0_") for f in occ[n]) and any(f.startswith("key1_") for f in occ[n])
    for n in NAMES:  # gt masks are for evaluation: only manual_masks lists masks in shot.json
        assert ("masks" in _load(ROOT / n)) == (n == "manual_masks")


def test_manual_masks_are_consistent():
    d = ROOT / "manual_masks"
    data = _load(d)
    assert data["masks"] == {"foreground": ["key0_fg.png", None], "occlusion": [["key0_occ0.png"], []]}
    fg = read_image(d / "key0_fg.png")[..., 0] > 0.5
    occ = read_image(d / "key0_occ0.png")[..., 0] > 0.5
    ink = read_image(d / "key0.png").mean(axis=2) < 0.5
    assert occ.sum() > 100 and not (occ & ~fg).any()
    assert not (ink & ~ndimage.binary_dilation(fg, iterations=2)).any()  # the mask covers the whole drawing
    np.testing.assert_array_equal(occ, read_image(d / "gt_occ" / "key0_occ0.png")[..., 0] > 0.5)
    # the occlusion lies where the arm crosses the torso: T-junctions sit on its boundary
    edge = ndimage.distance_transform_edt(~(occ ^ ndimage.binary_erosion(occ)))
    for x, y in data["t_junctions"][0]:
        assert edge[int(round(y)), int(round(x))] <= 3.0


@pytest.mark.parametrize("name", ["no_occlusion", "arm_cross", "tail"])
def test_explicit_poses_follow_the_interpolation_rule(name):
    """In-between poses = per-bone angle/length interpolation of the key poses (to the 0.01 px rounding)."""
    gen = _generator()
    data = _load(ROOT / name)
    parents = data["skeleton"]["parents"]
    poses = np.array([p["joints"] for p in data["poses"]], float)
    for i, p in enumerate(data["poses"]):
        np.testing.assert_allclose(gen.interpolate_pose(poses[0], poses[-1], p["t"], parents), poses[i], atol=0.011)
    lin = 0.5 * (poses[0] + poses[-1])  # a linear blend of joints would not reproduce the middle pose
    assert np.abs(lin - poses[len(poses) // 2]).max() > 1.0


def test_generator_interpolation_equals_loader():
    shot_mod = pytest.importorskip("ops.shotio.interpolate")
    gen = _generator()
    data = _load(ROOT / "two_poses")
    parents = data["skeleton"]["parents"]
    a, b = (np.array(p["joints"], float) for p in data["poses"])
    for s in np.linspace(0, 1, 9):
        np.testing.assert_allclose(gen.interpolate_pose(a, b, float(s), parents),
                                   shot_mod.interpolate_pose(a, b, float(s), np.array(parents)), atol=1e-9)


@pytest.mark.parametrize("name", NAMES)
def test_joints_inside_drawn_parts(name):
    gen = _generator()
    spec = gen.SHOTS[name]()
    _, poses = gen.output_poses(spec)
    look = gen.shot_look(spec)
    for pose in (poses[0], poses[-1]):
        fg = gen.shot_drawing(spec, pose, look).union > 0.5
        for p, c in spec.char.bones:
            mid = 0.5 * (pose[p, :2] + pose[c, :2])
            for x, y in (pose[p, :2], pose[c, :2], mid):
                assert fg[int(round(y)), int(round(x))], (name, p, c)


@pytest.mark.parametrize("end_y,expected", [
    (90.0, [(45, 45), (45, 55), (55, 45), (55, 55)]),  # a bar across a bar: 4 junctions
    (50.0, [(45, 45), (55, 45)]),  # a bar ending on top of another: 2
])
def test_t_junctions_are_outline_crossings(end_y, expected):
    """Analytic capsules: a horizontal bar behind, a vertical bar (radius 5) in front."""
    gen = _generator()
    part = gen.Part("capsule", 5.0, 0.0, "none")
    char = gen.Character(["a", "b", "c", "d"], [-1, 0, 1, 2], {1: part, 2: part, 3: part}, 0)
    pose = np.array([[20, 50, 0], [80, 50, 0], [50, 10, -1], [50, end_y, -1]], float)
    back, front = char.bones.index((0, 1)), char.bones.index((2, 3))
    rank = {b: r for r, b in enumerate(gen.draw_order(char, pose))}
    pts = gen.t_junctions(char, pose, front, back, rank)
    np.testing.assert_allclose(sorted(map(tuple, pts)), expected, atol=0.3)
    # a third part painted over one junction hides it
    cover = gen.Character(["a", "b", "c", "d", "e", "f"], [-1, 0, 1, 2, 0, 4], {c: part for c in range(1, 6)}, 0)
    pose2 = np.vstack([pose, [[100, 100, -2], [55, 45, -2]]])
    rank2 = {b: r for r, b in enumerate(gen.draw_order(cover, pose2))}
    pts2 = gen.t_junctions(cover, pose2, front, back, rank2)
    assert len(pts2) == len(expected) - 1 and np.min(np.hypot(*(pts2 - [55, 45]).T)) > 3


@pytest.mark.parametrize("name", ["tail", "two_poses"])
def test_regeneration_is_deterministic(tmp_path, name):
    gen = _generator()
    out = gen.generate(tmp_path, [name])[0]
    ref = ROOT / name
    assert (out / "shot.json").read_bytes() == (ref / "shot.json").read_bytes()
    files = sorted(p.relative_to(ref) for p in ref.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    for f in files:
        if f.suffix == ".png":
            np.testing.assert_array_equal(read_image(out / f), read_image(ref / f), err_msg=str(f))
        else:
            assert (out / f).read_bytes() == (ref / f).read_bytes(), f
