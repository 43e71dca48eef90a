"""The sample shots (v1 and v2) and their ground truth: loadable, regenerable, masks consistent, holes real."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from data_samples.generator.sequences import SEQUENCES, write_sequence
from data_samples.generator.shots import NEW_SHOTS, SHOTS
from data_samples.generator.write import generate, output_poses, shot_drawing, shot_look
from ops.shotio.image_io import read_image
from ops.shotio.load import ground_truth_files, load_shot

ROOT = Path(__file__).resolve().parents[2] / "data_samples"
NAMES = sorted(SHOTS)
SEQ_NAMES = sorted(SEQUENCES)  # the v2 samples: sequences of keys and one-drawing shots
HOLES = {("hand_on_hip", 0), ("hand_on_hip", 1), ("lamp", 0), ("curled_tail", 1)}  # enclosed paper by design
NO_HOLES = {("lamp", 1), ("curled_tail", 0), ("watercolour", 0), ("flat_colour", 0), ("scan_jpeg", 1)}


def _mask(path: Path) -> np.ndarray:
    """(H, W) bool of a white-on-black mask PNG."""
    return read_image(path)[..., 0] > 0.5


def _luminance(img: np.ndarray) -> np.ndarray:
    """(H, W) Rec. 709 luminance of an RGB float image."""
    return img[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def _holes(fg: np.ndarray) -> list[int]:
    """Areas (px) of the background components that do not touch the image border: enclosed paper."""
    lab, n = ndimage.label(~fg)
    border = set(np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]])))
    return [int((lab == k).sum()) for k in range(1, n + 1) if k not in border]


def test_all_shots_are_committed():
    assert sorted(p.parent.name for p in ROOT.glob("*/shot.json")) == sorted(NAMES + SEQ_NAMES)
    assert len(NEW_SHOTS) == 6 and set(NEW_SHOTS) < set(NAMES)


@pytest.mark.parametrize("name", SEQ_NAMES)
def test_v2_sample_loads_with_its_keys_and_ground_truth(name):
    shot = load_shot(ROOT / name)
    spec = SEQUENCES[name]()
    assert shot.version == 2 and shot.n_keys == (1 if spec.one_drawing else len(spec.keys))
    assert len(shot.times) == spec.n_frames and len(ground_truth_files(shot.ground_truth)) == spec.n_frames
    for k, f in enumerate(shot.key_frames):  # each keyframe is the ground truth at its frame, byte for byte
        assert (ROOT / name / f"key{k}.png").read_bytes() == (ROOT / name / "gt" / f"{f:04d}.png").read_bytes()
    pairs = json.loads((ROOT / name / "gt_occ" / "pairs.json").read_text())
    assert {p["keyframe"] for p in pairs} <= set(range(shot.n_keys))


@pytest.mark.parametrize("name", ["one_arm_swing", pytest.param("seq_dino_step", marks=pytest.mark.slow)])
def test_v2_sample_regenerates_identically(tmp_path, name):
    out = write_sequence(SEQUENCES[name](), tmp_path)
    ref = ROOT / name
    files = sorted(p.relative_to(ref) for p in ref.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    for f in files:
        assert (out / f).read_bytes() == (ref / f).read_bytes(), f


@pytest.mark.parametrize("name", NAMES)
def test_shot_loads(name):
    shot = load_shot(ROOT / name)
    assert len(shot.times) == 9 and shot.ground_truth is not None


@pytest.mark.parametrize("name", ["lamp", "scan_jpeg"] + [pytest.param(n, marks=pytest.mark.slow) for n in
                                                          ("watercolour", "flat_colour", "hand_on_hip", "curled_tail")])
def test_new_shot_regenerates_identically(tmp_path, name):
    out = generate(tmp_path, [name])[0]
    ref = ROOT / name
    files = sorted(p.relative_to(ref) for p in ref.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    for f in files:
        assert (out / f).read_bytes() == (ref / f).read_bytes(), f


@pytest.mark.parametrize("name", NAMES)
def test_occlusion_ground_truth_is_consistent(name):
    """Every mask lies inside the foreground; the union is their OR; the original (non-adjacent) masks are
    exactly the non-adjacent pairs; adjacency and depth order agree with the skeleton."""
    d = ROOT / name
    data = json.loads((d / "shot.json").read_text())
    parents = data["skeleton"]["parents"]
    bones = [(p, c) for c, p in enumerate(parents) if p >= 0]
    pairs = json.loads((d / "gt_occ" / "pairs.json").read_text())
    legacy = json.loads((d / "gt_occ" / "index.json").read_text())
    for k in range(2):
        fg = read_image(d / "gt_fg" / f"key{k}.png")[..., 0] >= 0.5
        union = _mask(d / "gt_occ" / f"key{k}_union.png")
        mine = [p for p in pairs if p["keyframe"] == k]
        acc = np.zeros_like(union)
        for p in mine:
            m = _mask(d / "gt_occ" / p["file"])
            assert m.sum() >= 12 and not (m & ~fg).any(), p["file"]
            acc |= m
            assert p["adjacent"] == bool(set(bones[p["front_bone"]]) & set(bones[p["back_bone"]]))
            assert p["front_depth"] <= p["back_depth"]
            assert not (p["joined"] and p["t_junctions"])  # one painted shape: no T-junction
        np.testing.assert_array_equal(acc, union)
        old = [e for e in legacy if e["keyframe"] == k]
        new = [p for p in mine if not p["adjacent"]]
        assert [(e["front_bone"], e["back_bone"]) for e in old] == [(p["front_bone"], p["back_bone"]) for p in new]
        for e, p in zip(old, new):
            np.testing.assert_array_equal(_mask(d / "gt_occ" / e["file"]), _mask(d / "gt_occ" / p["file"]))
    tj = [[q for e in legacy if e["keyframe"] == k for q in e["t_junctions"]] for k in range(2)]
    assert tj == data["t_junctions"]


@pytest.mark.parametrize("name,k", sorted(HOLES | NO_HOLES))
def test_enclosed_paper_is_a_hole_in_the_foreground(name, k):
    fg = read_image(ROOT / name / "gt_fg" / f"key{k}.png")[..., 0] >= 0.5
    big = [a for a in _holes(fg) if a >= 50]
    assert bool(big) == ((name, k) in HOLES), (name, k, _holes(fg))


def test_watercolour_has_no_dark_outline():
    """Luminance > 0.3 everywhere but on the black trousers; the ink lamp fails the same test."""
    spec = SHOTS["watercolour"]()
    _, poses = output_poses(spec)
    look = shot_look(spec)
    for k, pose in ((0, poses[0]), (1, poses[-1])):
        img = read_image(ROOT / "watercolour" / f"key{k}.png")
        cov = shot_drawing(spec, pose, look).coverage
        trousers = np.zeros(img.shape[:2], bool)
        for b, (_, c) in enumerate(spec.char.bones):
            if spec.char.parts[c].material == "trousers":
                trousers |= cov[b] > 0.02
        trousers = ndimage.binary_dilation(trousers, iterations=2)
        lum = _luminance(img)
        assert lum[~trousers].min() > 0.3
        assert np.percentile(lum[trousers], 25) < 0.3  # the trousers are black
    lamp = _luminance(read_image(ROOT / "lamp" / "key0.png"))
    assert lamp.min() < 0.2


def _paper_luminance_range(d: Path, key: str, k: int) -> float:
    """Spread (p99 - p1) of the paper's luminance, smoothed over 9 px, away from the character."""
    img = read_image(d / key)
    fg = read_image(d / "gt_fg" / f"key{k}.png")[..., 0] > 0.02
    paper = ~ndimage.binary_dilation(fg, iterations=6)
    lum = ndimage.median_filter(_luminance(img), size=9)
    return float(np.percentile(lum[paper], 99) - np.percentile(lum[paper], 1))


def test_scan_is_a_jpeg_on_unevenly_lit_paper():
    d = ROOT / "scan_jpeg"
    data = json.loads((d / "shot.json").read_text())
    for k, key in enumerate(data["keyframes"]):
        assert (d / key).read_bytes()[:3] == b"\xff\xd8\xff"  # JPEG
        assert _paper_luminance_range(d, key, k) > 0.06
    assert all(f.read_bytes()[:3] == b"\xff\xd8\xff" for f in (d / "gt").iterdir())
    assert _paper_luminance_range(ROOT / "lamp", "key0.png", 0) < 0.01  # white paper: the test can fail


@pytest.mark.parametrize("name", ["watercolour", "hand_on_hip"])
def test_noisy_paper_is_the_same_sheet_in_every_frame(name):
    """Wherever the character is not (in that frame), every ground-truth frame shows the shot's one textured sheet."""
    spec = SHOTS[name]()
    _, poses = output_poses(spec)
    look = shot_look(spec)
    sheet = np.round(look.paper.rgb * 255)
    assert np.std(sheet[..., 1]) > 1.0  # textured paper
    for i, pose in enumerate(poses):
        frame = np.round(read_image(ROOT / name / "gt" / f"{i:04d}.png") * 255)
        away = ~ndimage.binary_dilation(shot_drawing(spec, pose, look).union > 0, iterations=1)
        assert away.mean() > 0.5
        np.testing.assert_array_equal(frame[away], sheet[away])
