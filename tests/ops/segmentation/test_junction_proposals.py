"""Tests of T-junction proposals: the T's of a drawn occlusion are found where the outlines meet; the network's
NumPy forward pass is the torch one; its weights are checked before they load."""
from __future__ import annotations

import shutil

import cv2
import numpy as np
import pytest

from ops.segmentation import junction_infer
from ops.segmentation.junction_infer import IN_CHANNELS, STRIDE, junction_frame, to_keyframe
from ops.segmentation.junction_proposals import MERGE_PX, drawing_of, heat_peaks, propose_t_junctions
from ops.segmentation.network_input import to_work
from ops.types import Masks, Skeleton

S = 128
CENTRE, RADIUS = (56.0, 64.0), 34.0
BAR_Y0, BAR_Y1 = 58, 70  # a bar lying over the disc and out past its right side
BODY, ARM = (0.45, 0.75, 0.35), (0.85, 0.55, 0.3)
INK = (0.1, 0.15, 0.1)


def occluded_drawing() -> tuple[np.ndarray, np.ndarray]:
    """A round body with a 2 px outline and a bar in front of it crossing its right edge: (colour, coverage)."""
    img = np.ones((S, S, 3), np.float32)
    c = (int(CENTRE[0]), int(CENTRE[1]))
    cv2.circle(img, c, int(RADIUS), BODY, -1, cv2.LINE_AA)
    cv2.circle(img, c, int(RADIUS), INK, 2, cv2.LINE_AA)
    cv2.rectangle(img, (40, BAR_Y0), (115, BAR_Y1), ARM, -1)
    cv2.rectangle(img, (40, BAR_Y0), (115, BAR_Y1), INK, 2)
    cover = (np.abs(img - 1.0).sum(axis=2) > 0.02).astype(np.float32)
    return img, cover


def true_junctions() -> np.ndarray:
    """(2, 2) where the body's outline meets the bar's outline outside the bar (x > centre)."""
    pts = []
    for y in (BAR_Y0, BAR_Y1):
        dx = np.sqrt(RADIUS**2 - (y - CENTRE[1]) ** 2)
        pts.append((CENTRE[0] + dx, float(y)))
    return np.array(pts)


def masks_of(colour: np.ndarray, coverage: np.ndarray, occlusion: list[np.ndarray]) -> Masks:
    """Masks as build_masks would give them for a drawing on white paper."""
    fg = coverage > 0.5
    return Masks(foreground=fg, occlusion=occlusion, front_bones=[np.array([2])] * len(occlusion), source="predicted",
                 coverage=coverage, paper=np.ones(colour.shape, np.float32), colour=colour,
                 holes=np.zeros(fg.shape, bool), n_holes=0)


SKELETON = Skeleton(("hip", "neck", "shoulder", "hand"), np.array([-1, 0, 1, 2]))
# the body's bone runs down the disc; the arm (bone 2) along the bar, in front (smaller z); they share no joint
POSE = np.array([[56.0, 92.0, 0.0], [56.0, 36.0, 0.0], [46.0, 64.0, -1.0], [112.0, 64.0, -1.0]])


def _overlap() -> np.ndarray:
    yy, xx = np.mgrid[0:S, 0:S]
    return ((xx - CENTRE[0]) ** 2 + (yy - CENTRE[1]) ** 2 <= RADIUS**2) & (yy >= BAR_Y0) & (yy <= BAR_Y1)


def test_the_junctions_of_a_bar_over_a_disc_are_proposed_within_2_px():
    colour, coverage = occluded_drawing()
    props = propose_t_junctions(masks_of(colour, coverage, [_overlap()]), POSE, SKELETON)
    for t in true_junctions():
        d = np.linalg.norm(props.points - t, axis=1) if len(props.points) else np.array([np.inf])
        assert d.min() <= 2.0, f"no proposal within 2 px of {t}: {props.points.round(1)}"
        best = int(np.argmin(d))
        # the stem is the body's outline: it leaves the junction away from the bar, up or down
        assert abs(props.stems[best][1]) > 0.5
        assert (props.stems[best][1] < 0) == (t[1] == BAR_Y0)


def test_proposals_are_scored_sorted_and_apart():
    colour, coverage = occluded_drawing()
    props = propose_t_junctions(masks_of(colour, coverage, [_overlap()]), POSE, SKELETON, min_score=0.05)
    assert len(props.points) == len(props.scores) == len(props.stems) == len(props.regions) >= 2
    assert np.all(np.diff(props.scores) <= 0) and props.scores.min() >= 0.05 and props.scores.max() <= 1
    d = np.linalg.norm(props.points[:, None] - props.points[None], axis=2) + np.eye(len(props.points)) * 1e9
    assert d.min() >= MERGE_PX
    assert np.allclose(np.linalg.norm(props.stems, axis=1), 1.0)
    assert (props.regions == 0).all()


def test_two_lines_crossing_are_not_a_t():
    img = np.ones((S, S, 3), np.float32)
    cv2.rectangle(img, (30, 20), (98, 108), BODY, -1)
    cv2.rectangle(img, (30, 20), (98, 108), INK, 2)
    cv2.line(img, (40, 64), (88, 64), INK, 2, cv2.LINE_AA)  # texture strokes crossing on one body: nothing covered
    cv2.line(img, (64, 30), (64, 98), INK, 2, cv2.LINE_AA)
    cov = (np.abs(img - 1.0).sum(axis=2) > 0.02).astype(np.float32)
    pose = np.array([[64.0, 100.0, 0.0], [64.0, 28.0, 0.0], [40.0, 64.0, 0.0], [88.0, 64.0, 0.0]])
    props = propose_t_junctions(masks_of(img, cov, []), pose, SKELETON, min_score=0.05)
    assert not len(props.points) or np.linalg.norm(props.points - (64.0, 64.0), axis=1).min() > 3.0


def test_an_undivided_body_proposes_nothing():
    colour = np.ones((64, 64, 3), np.float32)
    cov = np.zeros((64, 64), np.float32)
    cov[20:40, 20:40] = 1.0
    colour[20:40, 20:40] = BODY
    props = propose_t_junctions(masks_of(colour, cov, []), POSE * 0.5, SKELETON)
    assert props.points.shape == (0, 2) and props.scores.shape == (0,)


def test_the_drawing_is_rebuilt_from_the_masks():
    colour, coverage = occluded_drawing()
    masks = masks_of(colour, coverage, [])
    masks.paper = np.full(colour.shape, 0.9, np.float32)
    img = drawing_of(masks)
    want = coverage[..., None] * colour + (1 - coverage[..., None]) * 0.9
    assert img.dtype == np.uint8 and np.abs(img / 255.0 - want).max() <= 0.5 / 255 + 1e-6


def test_heat_peaks_land_on_a_blob_and_a_plateau_gives_one():
    yy, xx = np.mgrid[0:40, 0:50].astype(np.float64)
    heat = np.exp(-((xx - 20.3) ** 2 + (yy - 10.0) ** 2) / 2.0) * 0.9
    heat[30:32, 40:42] = 0.5  # a 2 x 2 plateau
    heat[5, 5] = 0.2  # below the threshold
    pts, scores = heat_peaks(heat, 0.3)
    assert len(pts) == 2 and scores[0] >= scores[1]
    assert abs(pts[0][0] - 20.3) < 0.3 and abs(pts[0][1] - 10.0) < 0.05
    assert np.abs(pts[1] - (40.5, 30.5)).max() <= 1.0


def test_working_and_keyframe_pixels_round_trip():
    fg = np.zeros((300, 400), bool)
    fg[40:260, 100:300] = True
    pose = np.array([[120.0, 50.0, 0.0], [280.0, 250.0, 0.0]])
    frame = junction_frame(fg, pose)
    pts = np.array([[150.0, 80.0], [201.5, 199.25]])
    back = to_keyframe(to_work(np.c_[pts, np.zeros(2)], frame)[:, :2], frame)
    assert np.allclose(back, pts, atol=1e-9)


def test_a_tampered_weights_file_is_refused(tmp_path):
    good, path = tmp_path / "good.npz", tmp_path / "junction_unet.npz"
    shutil.copy(junction_infer.WEIGHTS_PATH, good)
    junction_infer.folded_weights(str(good), junction_infer.WEIGHTS_SHA256)  # the shipped bytes load
    data = bytearray(good.read_bytes())
    data[len(data) // 2] ^= 0xFF  # one byte of the compressed arrays
    path.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="sha256"):
        junction_infer.folded_weights(str(path), junction_infer.WEIGHTS_SHA256)
    with pytest.raises(FileNotFoundError, match="train_junctions"):
        junction_infer.folded_weights(str(tmp_path / "none.npz"), junction_infer.WEIGHTS_SHA256)


def test_numpy_inference_equals_the_torch_network():
    torch = pytest.importorskip("torch")
    from ops.segmentation.junction_net import load_network

    net = load_network()
    x = np.random.default_rng(3).normal(0, 0.5, (IN_CHANNELS, 2 * STRIDE, 3 * STRIDE)).astype(np.float32)
    with torch.no_grad():
        want = net(torch.from_numpy(x)[None])[0].numpy()
    got = junction_infer.junction_outputs(x)
    assert got.shape == want.shape
    assert np.abs(got - want).max() <= 1e-5 * max(1.0, float(np.abs(want).max()))


def test_proposals_never_import_torch():
    """The proposals run the network in NumPy: `inbetween junctions` and the editor never wait on torch."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    code = ("import sys\n"
            "from tests.ops.segmentation.test_junction_proposals import masks_of, occluded_drawing, POSE, SKELETON\n"
            "from ops.segmentation.junction_proposals import propose_t_junctions\n"
            "assert len(propose_t_junctions(masks_of(*occluded_drawing(), []), POSE, SKELETON).points)\n"
            "print('torch' in sys.modules)\n")
    root = str(Path(__file__).resolve().parents[3])
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=root,
                          env={**os.environ, "PYTHONPATH": root})
    assert done.returncode == 0 and done.stdout.strip() == "False", done.stderr[-2000:]
