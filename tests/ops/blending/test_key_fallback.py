"""The keys' own interpolation where neither lane is reliable (ops/blending/key_fallback.py)."""
from types import SimpleNamespace

import numpy as np
import pytest

import ops.blending.key_fallback as kf
from ops.blending.image_matrix import build_image_matrix
from ops.blending.key_fallback import fallback_weight, interpolate_keys, mix_premultiplied, with_key_fallback
from ops.evaluation.plate import over
from ops.types import DeformedSequence
from tests.ops.blending.test_image_matrix import disc_frames
from tests.ops.blending.test_local_alpha import onnx  # noqa: F401  (the fixture)


def _seq(images: np.ndarray, unreliable: np.ndarray) -> DeformedSequence:
    n = len(images)
    return DeformedSequence(np.linspace(0, 1, n), np.zeros((n, 1, 2)), images, unreliable, np.zeros(n),
                            np.zeros(n, np.int64))


def test_the_weight_is_the_lesser_lane_and_nothing_where_either_is_reliable():
    u0, u1 = np.zeros((60, 60), bool), np.zeros((60, 60), bool)
    u0[10:50, 10:50] = True
    u1[10:50, 30:50] = True  # both unreliable on x 30-49 only
    w = fallback_weight(u0, u1, sigma=2.0)
    assert w.min() >= 0 and w.max() <= 1
    np.testing.assert_array_equal(w, fallback_weight(u1, u0, sigma=2.0))  # symmetric
    # lane 0's tear reaches the meeting (x >= 30, less the blur) by sigma: its pixels further left keep lane 1
    assert w[:, :18].max() == 0
    assert w[30, 40] > 0.99  # deep inside both
    np.testing.assert_array_equal(fallback_weight(u0, np.zeros_like(u1)), 0)
    np.testing.assert_array_equal(fallback_weight(u0, u1, sigma=2.0, meet=2.0),  # never meeting: the lesser lane
                                  np.minimum(*(fallback_weight(u, u, sigma=2.0) for u in (u0, u1))))


def test_tears_that_meet_are_taken_whole_near_the_meeting_and_apart_they_are_left():
    """Each lane tears its own copy of a part, side by side: the per-pixel alpha would drop the part; near where
    the tears meet both come from the keys' interpolation. The same tears 40 px apart are the per-pixel alpha's."""
    sigma = 3.0
    u0, u1 = np.zeros((80, 120), bool), np.zeros((80, 120), bool)
    u0[30:50, 20:50] = True
    u1[30:50, 50:80] = True  # touching at x = 50, overlapping nowhere
    w = fallback_weight(u0, u1, sigma=sigma)
    lesser = np.minimum(*(fallback_weight(u, u, sigma=sigma) for u in (u0, u1)))
    assert lesser[40, 47] < 0.25 and lesser[40, 53] < 0.25  # the lesser lane alone: little, a sigma into a tear
    assert w[40, 47] > 0.9 and w[40, 53] > 0.9  # both tears near the meeting: the keys' interpolation
    assert w.sum() > 2 * lesser.sum()
    assert w[40, 20] < 0.05 and w[40, 79] < 0.05  # the tears' far ends stay the lanes'
    assert np.all(w >= lesser - 1e-7)
    far0, far1 = np.zeros_like(u0), np.zeros_like(u1)
    far0[30:50, 5:35] = True
    far1[30:50, 75:105] = True  # 40 px apart, more than 6 sigma
    np.testing.assert_array_equal(fallback_weight(far0, far1, sigma=sigma), 0)


def test_the_premultiplied_mix_is_the_mix_of_the_composites_over_any_paper():
    rng = np.random.default_rng(3)
    a, b = rng.random((2, 16, 16, 4)).astype(np.float32)
    a[0, :, 3] = 0  # transparent pixels: their stored colour must not leak
    w = rng.random((16, 16)).astype(np.float32)
    plate = rng.random((16, 16, 3)).astype(np.float32)
    mixed = mix_premultiplied(a, b, w)
    want = (1 - w[..., None]) * over(a[None], plate)[0] + w[..., None] * over(b[None], plate)[0]
    np.testing.assert_allclose(over(mixed[None], plate)[0], want, atol=1e-5)
    np.testing.assert_allclose(over(mix_premultiplied(a, b, np.zeros_like(w))[None], plate), over(a[None], plate),
                               atol=1e-6)  # weight 0: the frame


def test_reliable_lanes_and_small_specks_call_no_network_and_change_nothing():
    frames = disc_frames([30, 40, 50])
    none = np.zeros((3, 64, 96), bool)
    half = none.copy()
    half[:, :, 48:] = True  # one lane unreliable: the per-pixel alpha's case, not this one's
    speck = none.copy()
    speck[1, 30, 40] = True  # both lanes, one pixel: under MIN_SHARE of the frame (3 px here), not worth a call

    def no_network():
        raise AssertionError("the network was loaded")

    for u0, u1 in ((none, none), (none, half), (speck, speck)):
        out, weight = with_key_fallback(frames, _seq(frames, u0), _seq(frames, u1), np.linspace(0, 1, 3), no_network)
        np.testing.assert_array_equal(out, frames.astype(np.float32))
        assert weight.shape == frames.shape[:3] and not weight.any()


def test_doubly_unreliable_pixels_take_the_keys_interpolation_and_the_keys_stay(monkeypatch):
    frames = disc_frames([30, 40, 50, 60, 70])
    bad = np.zeros((5, 64, 96), bool)
    bad[:, :, 48:] = True  # both lanes, every frame, the keys included
    red = np.zeros_like(frames, np.float32)
    red[..., 0], red[..., 3] = 1.0, 1.0
    calls = []

    def keys_matrix(k0, k1, times, rife, depth, cells):  # red at every t; key0 alone in the fusion: no ghost
        calls.append(cells)
        cells_ = red[None, :, :k0.shape[0], :k0.shape[1]]
        return (SimpleNamespace(frames=cells_, flows=np.zeros((1, *k0.shape)), masks=np.ones((1, *k0.shape[:2])),
                                alphas=np.linspace(0, 1, 5)), np.arange(len(times)))

    monkeypatch.setattr(kf, "_keys_matrix", keys_matrix)
    out, weight = with_key_fallback(frames, _seq(frames, bad), _seq(frames, bad), np.linspace(0, 1, 5), lambda: None,
                                   sigma=2.0)
    assert calls == ["scaled"]  # one interpolation for the segment, one network call
    np.testing.assert_array_equal(out[[0, 4]], frames[[0, 4]].astype(np.float32))
    assert weight.min() >= 0 and weight.max() <= 1 and not weight[[0, 4]].any()  # the keys: weight 0
    share = (weight >= 0.5).mean((1, 2))  # the right half, less the blur's edge, taken at half weight or more
    assert np.all((share[1:4] > 0.4) & (share[1:4] < 0.6))
    assert (weight[1:4, :, 60:] > 0.99).all() and not weight[1:4, :, :40].any()
    np.testing.assert_allclose(out[1:4, :, 60:], red[1:4, :, 60:], atol=1e-6)  # deep in: the interpolation
    np.testing.assert_array_equal(out[1:4, :, :40], frames[1:4, :, :40].astype(np.float32))  # far: untouched


def test_interpolating_the_keys_is_the_bisection_of_the_image_matrix(onnx):  # noqa: F811
    f = disc_frames([36, 52])
    times = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    got = interpolate_keys(f[0], f[1], times, onnx)
    m = build_image_matrix(f[:1], f[1:], np.zeros(1), onnx, depth=2)
    np.testing.assert_array_equal(got, m.frames[0].astype(np.float32))
    coarse = interpolate_keys(f[0], f[1], times, onnx, max_depth=1)  # 1/4 and 3/4 are off the grid: nearest
    np.testing.assert_array_equal(coarse[[0, 2, 4]], got[[0, 2, 4]])
    assert not np.array_equal(coarse[1], got[1])
    scaled = interpolate_keys(f[0], f[1], times, onnx, cells="scaled")  # one call at 1/2, its flows scaled
    np.testing.assert_allclose(scaled[2], got[2], atol=2e-3)  # the midpoint is that call's (stored in half)
    np.testing.assert_allclose(scaled[[0, 4]], f, atol=2e-3)


@pytest.mark.parametrize("times, depth", [([0, 0.5, 1], 1), ([0, 0.25, 1], 2), ([0, 0.3, 1], 6)])
def test_dyadic_depth(times, depth):
    assert kf.dyadic_depth(np.array(times)) == depth


def test_the_keys_interpolated_on_the_box_around_the_weights_match_the_whole_frame(onnx):  # noqa: F811
    """The network sees the box around the weighted pixels plus its context, not the frame: near the same frames
    where a disc moves 16 px inside the box, the frame outside the box bit for bit."""
    frames = disc_frames([100, 108, 116], h=192, w=256, cy=96.0)
    bad = np.zeros((3, 192, 256), bool)
    bad[1, 88:104, 100:116] = True  # both lanes torn over the moving disc in the middle frame
    seen = []

    def network():
        class Watch:  # the network, noting the size of what it is given
            def __getattr__(self, name):
                attr = getattr(onnx, name)
                if name == "midpoint_flow_mask":
                    return lambda a, b, *r, **k: seen.append(a.shape[-2:]) or attr(a, b, *r, **k)
                return attr
        return Watch()

    times = np.linspace(0, 1, 3)
    whole, _ = with_key_fallback(frames, _seq(frames, bad), _seq(frames, bad), times, lambda: onnx, context=None)
    boxed, _ = with_key_fallback(frames, _seq(frames, bad), _seq(frames, bad), times, network, context=32)
    assert seen and all(h < 192 and w < 256 for h, w in seen)
    np.testing.assert_allclose(boxed, whole, atol=2.5 / 255)
    np.testing.assert_array_equal(boxed[1, :, :16], frames[1, :, :16])


def test_ghosting_is_where_the_warped_keys_differ_and_the_fusion_weighs_both():
    a, b = np.zeros((8, 8, 4), np.float32), np.zeros((8, 8, 4), np.float32)
    a[2, 3] = (0.2, 0.2, 0.2, 1.0)  # ink in key0 alone, premultiplied 0.2 and alpha 1
    flow = np.zeros((8, 8, 4), np.float32)  # no motion: each key warped onto itself
    both = kf.ghosting(a, b, flow, np.full((8, 8), 0.5, np.float32), 0.5)
    np.testing.assert_allclose(both[2, 3], 1.0)  # alpha differs by 1, the two keys weigh alike
    assert both[np.arange(8) != 2].max() == 0
    np.testing.assert_allclose(kf.ghosting(a, b, flow, np.ones((8, 8), np.float32), 0.5), 0)  # key0 alone
    np.testing.assert_allclose(kf.ghosting(a, a, flow, np.full((8, 8), 0.5, np.float32), 0.5), 0)  # agreeing keys


@pytest.mark.parametrize("fusion, ghosted", [(1.0, False), (0.5, True)])
def test_the_tears_that_meet_keep_off_where_rife_ghosts(monkeypatch, fusion, ghosted):
    """Two tears side by side take the keys' interpolation, unless RIFE's warped keys disagree there while its
    fusion weighs both (a ghost): then only the lesser lane's weight, near nothing beside the meeting, is left."""
    h, w = 80, 120
    frames = np.zeros((3, h, w, 4), np.float32)
    frames[0, ..., 3] = 1.0  # key0 all ink, key1 blank: where both weigh in, the warps differ by 1
    u0, u1 = np.zeros((3, h, w), bool), np.zeros((3, h, w), bool)
    u0[1, 30:50, 20:50] = True
    u1[1, 30:50, 50:80] = True

    def keys_matrix(k0, k1, times, rife, depth, cells):
        return (SimpleNamespace(frames=np.zeros((1, 3, *k0.shape)), flows=np.zeros((1, *k0.shape)),
                                masks=np.full((1, *k0.shape[:2]), fusion), alphas=np.linspace(0, 1, 3)),
                np.arange(len(times)))

    monkeypatch.setattr(kf, "_keys_matrix", keys_matrix)
    _, weight = with_key_fallback(frames, _seq(frames, u0), _seq(frames, u1), np.linspace(0, 1, 3), lambda: None,
                                 sigma=3.0)
    assert (weight[1, 40, 47] >= 0.5) != ghosted and (weight[1, 40, 53] >= 0.5) != ghosted


def test_ghosting_warps_as_rifes_own_blend_does():
    """OpenCV's remap (fast) against the warp RIFE's blend uses (ops/blending/rife_onnx.py), random flows."""
    from ops.blending.rife_onnx import scaled_flow_mask, warp
    rng = np.random.default_rng(0)
    k0, k1 = rng.random((2, 40, 50, 4)).astype(np.float32)
    flow = (rng.standard_normal((40, 50, 4)) * 5).astype(np.float32)
    mask = rng.random((40, 50)).astype(np.float32)
    pre = [np.concatenate((k[..., :3] * k[..., 3:], k[..., 3:]), -1).transpose(2, 0, 1)[None] for k in (k0, k1)]
    f, m = scaled_flow_mask(flow.transpose(2, 0, 1)[None], mask[None, None], 0.375)
    want = np.abs(warp(pre[0], f[:, :2]) - warp(pre[1], f[:, 2:4])).max(1)[0] * 4 * m[0, 0] * (1 - m[0, 0])
    np.testing.assert_allclose(kf.ghosting(k0, k1, flow, mask, 0.375), want, atol=1e-5)
