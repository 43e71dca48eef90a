"""Per-pixel alpha (ops/blending/local_alpha.py): the alpha map's rule, and frames blended with it."""
import numpy as np
import pytest

from ops.blending.crop import Box
from ops.blending.image_matrix import build_image_matrix
from ops.blending.local_alpha import local_alpha, local_frames
from ops.blending.rife import load_rife
from ops.blending.rife_onnx import OnnxRife
from ops.blending.select import select_frames
from ops.types import DeformedSequence
from tests.ops.blending.test_image_matrix import disc_frames


@pytest.fixture(scope="module")
def onnx(tmp_path_factory):
    rife = load_rife(runtime="onnxruntime", cache_dir=tmp_path_factory.mktemp("onnx"))
    if not isinstance(rife, OnnxRife):
        pytest.skip("onnxruntime is not installed")
    return rife


def test_the_alpha_moves_toward_the_reliable_lane_and_nowhere_else():
    u0, u1 = np.zeros((40, 40), bool), np.zeros((40, 40), bool)
    u0[10:20, 10:20] = True  # lane 0 inpainted here: take lane 1
    u1[25:35, 25:35] = True  # lane 1 torn here: take lane 0
    a = local_alpha(0.5, u0, u1, strength=1.0)
    assert a.dtype == np.float32 and a.shape == (40, 40)
    assert a[15, 15] > 0.95 and a[30, 30] < 0.05  # the middle of each blob: (nearly) all the reliable lane
    assert a[2, 38] == pytest.approx(0.5) and a[38, 2] == pytest.approx(0.5)  # far from both: the frame's alpha
    assert (a >= 0).all() and (a <= 1).all()
    np.testing.assert_allclose(local_alpha(0.25, u0, u0, 3.0), 0.25)  # alike lanes: unchanged
    np.testing.assert_allclose(local_alpha(0.5, u0, u1, 0.0), 0.5)  # strength 0: the paper's single alpha
    half = local_alpha(0.5, u0, u1, 0.5)
    inside = (a > 0) & (a < 1)
    np.testing.assert_allclose((half - 0.5)[inside], 0.5 * (a - 0.5)[inside], atol=1e-6)  # linear below the clip


def test_alpha_is_exactly_the_frames_beyond_three_blur_radii():
    u0 = np.zeros((60, 60), bool)
    u0[28:32, 28:32] = True
    a = local_alpha(0.375, u0, np.zeros_like(u0), strength=2.0, sigma=3.0)
    moved = np.argwhere(a != np.float32(0.375))
    assert len(moved) and moved.min() >= 28 - 9 and moved.max() <= 31 + 9


def test_a_region_of_the_blend_is_that_region_of_the_whole_blend(onnx):
    f0, f1 = disc_frames([36, 40]), disc_frames([52, 44])
    a0, a1 = f0.transpose(0, 3, 1, 2), f1.transpose(0, 3, 1, 2)
    _, flow, mask = onnx.midpoint_flow_mask(a0, a1)
    alpha = np.random.default_rng(0).random(mask.shape).astype(np.float32)
    whole = OnnxRife.blend_at(a0, a1, flow, mask, alpha)
    for box in (Box(10, 40, 30, 70), Box(0, 64, 0, 96), Box(0, 5, 0, 5)):  # across the ink, all, paper only
        part = OnnxRife.blend_at(a0, a1, flow, mask, alpha, box)
        np.testing.assert_array_equal(part, whole[..., box.y0:box.y1, box.x0:box.x1])


def test_a_uniform_alpha_map_blends_as_the_number(onnx):
    f0, f1 = disc_frames([36, 40]), disc_frames([52, 44])
    _, flow, mask = onnx.midpoint_flow_mask(f0.transpose(0, 3, 1, 2), f1.transpose(0, 3, 1, 2))
    a0, a1 = f0.transpose(0, 3, 1, 2), f1.transpose(0, 3, 1, 2)
    for alpha in (0.0, 0.3, 0.5, 1.0):
        scalar = OnnxRife.blend_at(a0, a1, flow, mask, alpha)
        array = OnnxRife.blend_at(a0, a1, flow, mask, np.full(mask.shape, alpha, np.float32))
        np.testing.assert_allclose(array, scalar, atol=1e-6)


def test_frames_change_only_where_a_lane_is_unreliable_and_never_at_the_keys(onnx):
    # a disc moving right; lane 0 has inpainted texture on its right half at the middle frame
    f0 = disc_frames([30, 34, 38])
    f1 = disc_frames([50, 54, 58])
    times = np.linspace(0, 1, 3)
    m = build_image_matrix(f0, f1, times, onnx, depth=2, cells="scaled")
    path = np.array([0, 2, 4])  # alphas 0, 1/2, 1
    frames = select_frames(m.frames, path, m.computed)
    none = np.zeros((3, 64, 96), bool)
    seq = lambda imgs, inp: DeformedSequence(times, np.zeros((3, 1, 2)), imgs, inp, np.zeros(3),
                                             np.zeros(3, np.int64))
    same, moved = local_frames(frames, seq(f0, none), seq(f1, none), m, m.alphas[path], strength=1.0)
    np.testing.assert_array_equal(same, frames.astype(np.float32))  # both lanes reliable: the path's cells
    assert not moved.any()
    bad = none.copy()
    bad[:, :, 48:] = True  # every frame of lane 0, even the keys: the keys stay
    out, moved = local_frames(frames, seq(f0, bad), seq(f1, none), m, m.alphas[path], strength=1.0)
    np.testing.assert_array_equal(out[[0, 2]], frames[[0, 2]].astype(np.float32))
    assert moved[0] == moved[2] == 0 and 0.4 < moved[1] < 0.6
    # the left, over four blur radii from the inpainted half: alpha 1/2 as before
    np.testing.assert_allclose(out[1, :, :36], frames[1, :, :36], atol=1e-3)
    # the right: nearer lane 1's frame, whose disc sits further right (its ink's centre moves right)
    xx = np.arange(96)[None, :]
    centre = lambda img: (img[..., 3] * xx).sum() / img[..., 3].sum()
    assert centre(out[1]) > centre(frames[1].astype(np.float32)) + 0.5
    with pytest.raises(ValueError, match="scaled"):
        bisected = build_image_matrix(f0, f1, times, onnx, depth=2)
        local_frames(frames, seq(f0, bad), seq(f1, none), bisected, m.alphas[path], 1.0)
