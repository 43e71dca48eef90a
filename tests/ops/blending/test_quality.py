"""Quality measures: analytic flows for the divergence, exact shares, table layout."""
import numpy as np
import pytest

from ops.blending.quality import (
    coverage_weight,
    flow_divergence,
    inpainted_share,
    interpolation_quality,
    quality_table,
    texture_quality,
    unreliable_share,
)
from ops.types import DeformedSequence

H, W = 24, 32


def _grid():
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    return x, y


def test_divergence_of_translation_is_zero():
    flow = np.zeros((H, W, 2))
    flow[..., 0], flow[..., 1] = 3.5, -2.0
    np.testing.assert_allclose(flow_divergence(flow), 0.0, atol=1e-12)


def test_divergence_of_uniform_expansion_is_2s():
    x, y = _grid()
    s = 0.07
    flow = np.stack([s * x, s * y], axis=-1)
    np.testing.assert_allclose(flow_divergence(flow), 2 * s, atol=1e-12)


def test_divergence_of_shear_is_zero_not_s():
    # u = s y, v = 0: a shear; differentiating u along rows (the axis mistake) gives s.
    x, y = _grid()
    s = 0.3
    flow = np.stack([s * y, np.zeros_like(y)], axis=-1)
    div = flow_divergence(flow)
    np.testing.assert_allclose(div, 0.0, atol=1e-12)
    wrong = np.gradient(flow[..., 0], axis=0) + np.gradient(flow[..., 1], axis=1)
    assert np.allclose(wrong, s)  # the mistake really would show up


def test_divergence_non_square_axes():
    # u depends on x only, v on y only, with different rates: checks each axis separately.
    x, y = _grid()
    flow = np.stack([0.1 * x ** 2, -0.5 * y], axis=-1)
    expected = 0.2 * x - 0.5
    div = flow_divergence(flow)
    # central differences are exact for quadratics in the interior
    np.testing.assert_allclose(div[:, 1:-1], expected[:, 1:-1], atol=1e-12)


def test_interpolation_quality_sums_both_flows_and_weight():
    x, y = _grid()
    s0, s1 = 0.1, 0.05
    flows = np.zeros((3, H, W, 4))
    flows[1, ..., 0], flows[1, ..., 1] = s0 * x, s0 * y      # div = 2 s0
    flows[2, ..., 2], flows[2, ..., 3] = -s1 * x, -s1 * y    # div = -2 s1
    flows[2, ..., 0] = 4.0                                     # translation adds nothing
    Q = interpolation_quality(flows)
    np.testing.assert_allclose(Q, [0.0, (2 * s0) ** 2, (2 * s1) ** 2], rtol=1e-12)
    weight = np.zeros((3, H, W), bool)
    weight[:, :10, :5] = True
    Qw = interpolation_quality(flows, weight)
    np.testing.assert_allclose(Qw, [0.0, (2 * s0) ** 2 * 50 / (H * W), (2 * s1) ** 2 * 50 / (H * W)], rtol=1e-12)


def test_coverage_weight_is_union():
    a0 = np.zeros((1, 2, 2)); a1 = np.zeros((1, 2, 2))
    a0[0, 0, 0] = 0.5; a1[0, 1, 1] = 1.0
    np.testing.assert_array_equal(coverage_weight(a0, a1)[0], [[True, False], [False, True]])


def test_inpainted_share_weighted_by_alpha():
    alpha = np.zeros((3, 4, 4), np.float32)
    inp = np.zeros((3, 4, 4), bool)
    alpha[0] = 1.0                      # clean frame
    alpha[1, :2] = 1.0; alpha[1, 2:] = 0.5
    inp[1, 2:] = True                   # inpainted half-covered rows: 4 / (8 + 4)
    inp[2] = True                       # empty frame -> 0, not nan
    share = inpainted_share(inp, alpha)
    np.testing.assert_allclose(share, [0.0, 4.0 / 12.0, 0.0])


def test_texture_quality_linear_and_zero_at_keyframes():
    rng = np.random.default_rng(0)
    T = 6
    share0, share1 = rng.random(T), rng.random(T)
    share0[0] = 0.0; share1[-1] = 0.0   # each keyframe is clean in its own sequence
    alphas = np.linspace(0, 1, 9)
    q = texture_quality(share0, share1, alphas)
    assert q.shape == (T, 9)
    assert q[0, 0] == 0.0 and q[-1, -1] == 0.0
    np.testing.assert_allclose(q[:, 0], share0)
    np.testing.assert_allclose(q[:, -1], share1)
    np.testing.assert_allclose(q[:, 4], 0.5 * (share0 + share1))
    # linear in alpha: second differences vanish
    np.testing.assert_allclose(np.diff(q, 2, axis=1), 0.0, atol=1e-12)


def test_quality_table_long_format():
    times = np.array([0.0, 0.5, 1.0]); alphas = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    q = np.arange(15, dtype=float).reshape(3, 5); Q = np.array([1.0, 2.0, 3.0])
    df = quality_table(times, alphas, q, Q)
    assert list(df.columns) == ["t", "alpha", "q", "Q"] and len(df) == 15
    row = df[(df.t == 0.5) & (df.alpha == 0.75)]
    assert len(row) == 1 and row.q.item() == q[1, 3] and row.Q.item() == 2.0
    with pytest.raises(ValueError):
        quality_table(times, alphas, q.T, Q)


def test_unreliable_share_counts_inpainted_and_distorted_pixels_once():
    alpha = np.ones((2, 4, 4), np.float32)
    inp = np.zeros((2, 4, 4), bool)
    dist = np.zeros((2, 4, 4), bool)
    inp[0, 0] = True  # 4 pixels
    dist[0, :2] = True  # 8 pixels, 4 of them also inpainted
    seq = DeformedSequence(np.array([0.0, 1.0]), np.zeros((2, 3, 2)), np.concatenate([np.zeros((2, 4, 4, 3)),
                           alpha[..., None]], -1), inp, np.zeros(2), np.zeros(2, np.int64), dist)
    np.testing.assert_allclose(unreliable_share(seq), [8 / 16, 0.0])
    seq.distorted = None  # a lane stored before distortion was measured: the paper's q
    np.testing.assert_allclose(unreliable_share(seq), [4 / 16, 0.0])
