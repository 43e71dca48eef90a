"""Tests of ops.image_matrix: dyadic grid, bisection bookkeeping, endpoints, motion, memmap output."""
import time

import numpy as np
import pytest

from ops.blending.image_matrix import (
    alpha_grid,
    bisection_closure,
    bisection_levels,
    build_image_matrix,
    complete_cells,
)
from ops.blending.rife import load_rife
from ops.blending.rife_onnx import OnnxRife
from ops.cputime import charged


@pytest.fixture(scope="module")
def rife():
    """The real network (float32, CPU)."""
    return load_rife()


class AveragingFake(OnnxRife):
    """Stand-in for the network whose midpoint is the pixel average, on the NumPy runtime's arrays; records each
    call's batch size."""

    def __init__(self):
        self.calls = []

    def midpoint_tensors(self, img0, img1):
        """(N, 4, H, W) pair -> (average, flow filled with the batch size)."""
        self.calls.append(len(img0))
        return (img0 + img1) / 2, np.full(img0.shape, float(len(img0)), np.float32)

    def midpoint_flow_mask(self, img0, img1):
        """midpoint_tensors with an even mask (the scaled cells then blend the frames with the flows scaled)."""
        mid, flow = self.midpoint_tensors(img0, img1)
        return mid, flow, np.full((len(img0), 1) + img0.shape[2:], 0.5, np.float32)


def random_frames(t, h=16, w=12, seed=0):
    """(t, h, w, 4) float32 uniform random RGBA."""
    return np.random.default_rng(seed).random((t, h, w, 4), dtype=np.float32)


def disc_frames(centres, h=64, w=96, cy=32.0, r=10.0):
    """(T, h, w, 4) float32: a dark disc (alpha = coverage) at each x centre, transparent elsewhere."""
    yy, xx = np.mgrid[:h, :w].astype(np.float32)
    img = np.zeros((len(centres), h, w, 4), np.float32)
    img[..., :3] = 0.1
    img[..., 3] = np.clip(r + 0.5 - np.hypot(xx[None] - np.asarray(centres, np.float32)[:, None, None], yy - cy), 0, 1)
    return img


def test_alpha_grid_values():
    """Depth d gives the 2**d + 1 multiples of 1/2**d; depth 0 is refused (no alpha = 1/2)."""
    np.testing.assert_array_equal(alpha_grid(1), [0.0, 0.5, 1.0])
    g = alpha_grid(3)
    assert g.dtype == np.float64 and len(g) == 9
    np.testing.assert_array_equal(g * 8, np.arange(9))
    with pytest.raises(ValueError):
        alpha_grid(0)


@pytest.mark.parametrize("depth", [1, 2, 3, 4])
def test_bisection_fills_each_interior_once_from_known_parents(depth):
    """Every interior index is filled exactly once, at the midpoint of two already known indices."""
    n = 2**depth
    known = {0, n}
    for triples in bisection_levels(depth):
        lo, mid, hi = triples.T
        assert np.all(lo + hi == 2 * mid)
        assert all(i in known for i in np.r_[lo, hi]) and not any(m in known for m in mid)
        known |= set(mid.tolist())
    assert known == set(range(n + 1))


@pytest.mark.parametrize("batch", [1, 3, 8])
def test_averaging_midpoints_give_linear_blend(batch):
    """With an averaging midpoint, bisection yields (1 - alpha) f0 + alpha f1 exactly, in calls of <= batch."""
    f0, f1 = random_frames(5), random_frames(5, seed=1)
    fake = AveragingFake()
    m = build_image_matrix(f0, f1, np.linspace(0, 1, 5), fake, depth=3, batch=batch)
    a = m.alphas[None, :, None, None, None]
    np.testing.assert_allclose(m.frames, (1 - a) * f0[:, None] + a * f1[:, None], atol=1e-6)
    assert max(fake.calls) <= batch and sum(fake.calls) == 5 * 7  # 2**3 - 1 midpoints per time
    assert m.frames.shape == (5, 9, 16, 12, 4) and m.flows.shape == (5, 16, 12, 4)


def test_flow_is_the_level_one_flow():
    """The kept flow per time is the one returned by the alpha = 1/2 call (here tagged with its batch size)."""
    f0, f1 = random_frames(3), random_frames(3, seed=1)
    m = build_image_matrix(f0, f1, np.linspace(0, 1, 3), AveragingFake(), depth=2, batch=4)
    # rows chunked by 4 -> level 1 of the single chunk is one call of 3 pairs
    np.testing.assert_array_equal(m.flows, 3.0)


def test_bad_shapes_are_refused():
    """Mismatched frames, times or out arrays raise ValueError."""
    f = random_frames(2)
    with pytest.raises(ValueError):
        build_image_matrix(f, f[:1], np.zeros(2), AveragingFake())
    with pytest.raises(ValueError):
        build_image_matrix(f, f, np.zeros(3), AveragingFake())
    with pytest.raises(ValueError):
        build_image_matrix(f, f, np.zeros(2), AveragingFake(), depth=2, out=np.zeros((2, 4, 16, 12, 4), np.float32))


def test_real_matrix_endpoints_motion_and_memmap(rife, tmp_path):
    """Real RIFE: exact endpoints, disc centre moving monotonically ~linearly in alpha, memmap == in-memory."""
    f0 = disc_frames([36, 40])
    f1 = disc_frames([52, 40])  # row 1: identical frames
    times = np.array([0.0, 1.0])
    m = build_image_matrix(f0, f1, times, rife, depth=3, batch=8)
    np.testing.assert_array_equal(m.frames[:, 0], f0)
    np.testing.assert_array_equal(m.frames[:, -1], f1)
    xx = np.arange(96)[None, :]
    alpha = m.frames[0, ..., 3]  # (A, H, W)
    cx = (alpha * xx).sum(axis=(1, 2)) / alpha.sum(axis=(1, 2))
    assert np.all(np.diff(cx) > 0)
    np.testing.assert_allclose(cx, 36 + 16 * m.alphas, atol=1.5)
    np.testing.assert_allclose(m.frames[1], np.broadcast_to(f0[1], m.frames[1].shape), atol=1e-3)
    assert abs(m.flows[0, 32, 44, 0] + 8) < 1.5 and abs(m.flows[0, 32, 44, 2] - 8) < 1.5

    mm = np.lib.format.open_memmap(tmp_path / "matrix.npy", mode="w+", dtype=np.float32, shape=m.frames.shape)
    m2 = build_image_matrix(f0, f1, times, rife, depth=3, batch=8, out=mm)
    assert m2.frames is mm
    mm.flush()
    np.testing.assert_array_equal(np.load(tmp_path / "matrix.npy"), m.frames)
    # one row per chunk and one pair per call: only float noise from other conv batch sizes
    m3 = build_image_matrix(f0, f1, times, rife, depth=3, batch=1)
    np.testing.assert_allclose(m3.frames, m.frames, atol=1e-4)
    np.testing.assert_allclose(m3.flows, m.flows, atol=1e-3)


@pytest.mark.parametrize("depth", [1, 2, 3, 4])
def test_bisection_closure_is_exactly_the_ancestors(depth):
    """The closure of random cells = them, their bisection ancestors (brute force), both ends and alpha 1/2."""
    n = 2**depth
    rng = np.random.default_rng(depth)
    wanted = rng.random((6, n + 1)) < 0.15
    parents = {}
    for triples in bisection_levels(depth):
        for lo, mid, hi in triples:
            parents[int(mid)] = (int(lo), int(hi))

    def ancestors(a):
        out = {a}
        for p in parents.get(a, ()):
            out |= ancestors(p)
        return out

    need = bisection_closure(wanted, depth)
    for t in range(6):
        expect = {0, n, n // 2}.union(*[ancestors(int(a)) for a in np.nonzero(wanted[t])[0]])
        assert set(np.nonzero(need[t])[0].tolist()) == expect


def test_only_wanted_cells_are_blended_after_the_flows():
    """wanted() sees the alpha-1/2 flows; only its cells and their ancestors are blended, each exactly as in
    the full matrix; the rest is zero and marked not computed."""
    f0, f1 = random_frames(4), random_frames(4, seed=1)
    times = np.linspace(0, 1, 4)
    full = build_image_matrix(f0, f1, times, AveragingFake(), depth=3)
    assert full.computed.all()
    seen = []
    pick = np.zeros((4, 9), bool)
    pick[1, 3] = pick[2, 8] = pick[3, 6] = True

    def wanted(flows):
        seen.append(flows.copy())
        return pick

    fake = AveragingFake()
    m = build_image_matrix(f0, f1, times, fake, depth=3, wanted=wanted)
    np.testing.assert_array_equal(seen[0], 1.0)  # the level-1 flows (batch size 1) were known when choosing
    np.testing.assert_array_equal(m.computed, bisection_closure(pick, 3))
    assert sum(fake.calls) == m.computed[:, 1:-1].sum() == 4 + 2 + 1  # alpha 1/2 per row; 1/4 and 3/8; 3/4
    np.testing.assert_array_equal(m.frames[m.computed], full.frames[m.computed])
    np.testing.assert_array_equal(m.frames[~m.computed], 0.0)
    np.testing.assert_array_equal(m.flows, full.flows)


def test_completing_another_path_blends_only_its_new_cells():
    """A matrix built for one path, completed along another: the new cells and their parents are blended, each
    exactly as in the full matrix, cells it had are neither blended again nor changed, and the flows stay."""
    f0, f1 = random_frames(5), random_frames(5, seed=1)
    times = np.linspace(0, 1, 5)
    full = build_image_matrix(f0, f1, times, AveragingFake(), depth=3)
    first = np.array([0, 0, 3, 8, 8])  # a path that jumps to key 1
    diagonal = np.array([0, 2, 4, 6, 8])
    pick = np.zeros((5, 9), bool)
    pick[np.arange(5), first] = True
    m = build_image_matrix(f0, f1, times, AveragingFake(), depth=3, wanted=lambda flows: pick)
    before = m.frames.copy()
    fake = AveragingFake()
    done = complete_cells(m, f0, f1, fake, diagonal)
    want = pick.copy()
    want[np.arange(5), diagonal] = True
    np.testing.assert_array_equal(done.computed, bisection_closure(want, 3))
    assert sum(fake.calls) == (done.computed & ~m.computed).sum() > 0
    np.testing.assert_array_equal(done.frames[done.computed], full.frames[done.computed])
    np.testing.assert_array_equal(m.frames, before)  # the stored matrix is not changed
    np.testing.assert_array_equal(done.flows, m.flows)
    again = AveragingFake()
    assert complete_cells(done, f0, f1, again, diagonal) is done and not again.calls


def test_rows_filled_at_once_equal_rows_filled_in_turn(tmp_path):
    """ONNX Runtime fills the rows on two threads, one network thread each (OnnxRife.concurrency), and a row left
    over on both: the same matrix as one row after the other on both threads, to float noise, and the same cells
    computed."""
    onnx = load_rife(runtime="onnxruntime", cache_dir=tmp_path)
    if not isinstance(onnx, OnnxRife):
        pytest.skip("onnxruntime is not installed")
    f0 = disc_frames([30, 36, 40, 44, 50])
    f1 = disc_frames([56, 52, 48, 44, 40])
    times = np.linspace(0, 1, 5)

    def wanted(flows):
        pick = np.zeros((5, 9), bool)
        pick[:, [0, 2, 4, 7, 8]] = True
        return pick

    together = build_image_matrix(f0, f1, times, onnx, depth=3, wanted=wanted)

    class InTurn(OnnxRife):
        def concurrency(self):
            return 1

    alone = InTurn(onnx.onnx_path, onnx.weights_path)
    in_turn = build_image_matrix(f0, f1, times, alone, depth=3, wanted=wanted)
    np.testing.assert_array_equal(together.computed, in_turn.computed)
    np.testing.assert_allclose(together.frames, in_turn.frames, atol=1e-5)
    np.testing.assert_allclose(together.flows, in_turn.flows, atol=1e-4)
    cores = onnx.concurrency()
    if cores > 1:
        # the calls made at once ran on their share of the threads; a row left over once the others are paired
        # (five rows: the fifth of each phase's) ran alone, on all of them
        at_once = min(cores, 5)
        shared = {(max(1, cores // at_once), False)}
        assert set(onnx._sessions) == (shared | {(cores, False)} if 5 % at_once else shared)
        assert set(alone._sessions) == {(cores, False)}
    assert onnx._callers == 1  # back to whole calls once the matrix is built


def test_a_failing_row_fails_the_matrix():
    """An error in one of the rows filled at once reaches the caller (not lost on a worker thread)."""
    class Failing(AveragingFake):
        def concurrency(self):
            return 2

        def midpoint_tensors(self, img0, img1):
            if len(self.calls) >= 3:
                raise RuntimeError("network failed")
            return super().midpoint_tensors(img0, img1)

    f0, f1 = random_frames(6), random_frames(6, seed=1)
    with pytest.raises(RuntimeError, match="network failed"):
        build_image_matrix(f0, f1, np.linspace(0, 1, 6), Failing(), depth=2)


def test_the_rows_cpu_on_the_pool_is_charged_to_the_thread_that_built_the_matrix():
    # a stage's cpu_seconds counts the network calls its matrix made on the pool's threads (ops.cputime)
    class Spinning(AveragingFake):
        def concurrency(self):
            return 2

        def midpoint_tensors(self, img0, img1):
            start = time.thread_time()
            while time.thread_time() - start < 0.05:
                pass
            return super().midpoint_tensors(img0, img1)

    fake = Spinning()
    before, here = charged(), time.thread_time()
    build_image_matrix(random_frames(6), random_frames(6, seed=1), np.linspace(0, 1, 6), fake, depth=2)
    on_pool, own = charged() - before, time.thread_time() - here
    assert on_pool >= 0.1  # at least two calls ran on the pool
    assert on_pool + own >= 0.05 * len(fake.calls)  # every call's CPU is counted, wherever it ran


class CountingOnnx(OnnxRife):
    """The real network on ONNX Runtime, counting the pairs it is called on."""

    def __init__(self, onnx_path, weights_path):
        super().__init__(onnx_path, weights_path)
        self.pairs = 0

    def _run(self, rgb0, rgb1):
        with self._lock:
            self.pairs += len(rgb0)
        return super()._run(rgb0, rgb1)


@pytest.fixture(scope="module")
def onnx(tmp_path_factory):
    rife = load_rife(runtime="onnxruntime", cache_dir=tmp_path_factory.mktemp("onnx"))
    if not isinstance(rife, OnnxRife):
        pytest.skip("onnxruntime is not installed")
    return CountingOnnx(rife.onnx_path, rife.weights_path)


def test_scaled_cells_cost_one_call_a_row_and_move_the_disc_linearly(onnx):
    """Scaled cells: the network runs once per moving row, at alpha 1/2, whose cells and flows are the bisected
    matrix's; the ends are the frames; every other cell shows the disc a share alpha of the way (as bisection
    does, to 1.5 px), and the row of identical frames is that frame in every cell."""
    f0, f1 = disc_frames([36, 40]), disc_frames([52, 40])
    times = np.array([0.0, 1.0])
    onnx.pairs = 0
    m = build_image_matrix(f0, f1, times, onnx, depth=3, cells="scaled")
    assert onnx.pairs == 1 and m.computed.all() and m.masks.shape == (2, 64, 96)
    bisected = build_image_matrix(f0, f1, times, onnx, depth=3)
    # scaled cells are kept in half precision, bisected ones in single: equal to half a step of a half below 1
    assert m.frames.dtype == np.float16 and bisected.frames.dtype == np.float32
    np.testing.assert_allclose(m.frames[:, 4], bisected.frames[:, 4], atol=2.5e-4)
    np.testing.assert_allclose(m.flows, bisected.flows, atol=1e-4)
    assert bisected.masks is None
    np.testing.assert_array_equal(m.frames[:, 0], f0.astype(np.float16))
    np.testing.assert_array_equal(m.frames[:, -1], f1.astype(np.float16))
    xx = np.arange(96)[None, :]
    alpha = m.frames[0, ..., 3].astype(np.float32)
    cx = (alpha * xx).sum(axis=(1, 2)) / alpha.sum(axis=(1, 2))
    assert np.all(np.diff(cx) > 0)
    np.testing.assert_allclose(cx, 36 + 16 * m.alphas, atol=1.5)
    np.testing.assert_allclose(m.frames[1], np.broadcast_to(f0[1], m.frames[1].shape), atol=2.5e-4)
    # the scaled cells are near bisection's (the cells at eighths and quarters of a 16 px move)
    assert np.abs(m.frames[0] - bisected.frames[0]).mean() < 0.01


@pytest.mark.parametrize("runtime", ["onnxruntime", "torch"])
def test_blend_at_one_half_is_the_midpoint_and_its_ends_are_the_frames(runtime, tmp_path):
    """blend_at with the midpoint's own flow and mask: alpha 1/2 gives the midpoint, 0 and 1 the two frames."""
    rife = load_rife(runtime=runtime, cache_dir=tmp_path)
    f0, f1 = disc_frames([30, 44]), disc_frames([46, 44])
    f1[1, ..., 3] *= 0.5  # a pair that moves only in coverage
    a0, a1 = rife.rgba_tensor(f0), rife.rgba_tensor(f1)
    mid, flow, mask = rife.midpoint_flow_mask(a0, a1)
    host = rife.to_host
    np.testing.assert_allclose(host(rife.blend_at(a0, a1, flow, mask, 0.5)), host(mid), atol=1e-5)
    def premultiplied(img):  # a transparent pixel's colour is nothing to compare
        return np.concatenate((img[..., :3] * img[..., 3:], img[..., 3:]), -1)

    np.testing.assert_allclose(premultiplied(host(rife.blend_at(a0, a1, flow, mask, 0.0))), premultiplied(f0), atol=1e-5)
    np.testing.assert_allclose(premultiplied(host(rife.blend_at(a0, a1, flow, mask, 1.0))), premultiplied(f1), atol=1e-5)
    m2, f2 = rife.midpoint_tensors(a0, a1)
    np.testing.assert_array_equal(host(m2), host(mid))
    np.testing.assert_array_equal(host(f2), host(flow))


def test_completing_a_scaled_matrix_calls_no_network(onnx):
    """A scaled matrix built for one path and completed along another: no network call, the new cells as the
    full scaled matrix's, the path's own and the flows and masks unchanged; only alpha 1/2 and the wanted cells
    are computed."""
    f0 = disc_frames([30, 36, 40, 44, 50])
    f1 = disc_frames([56, 52, 48, 44, 40])
    times = np.linspace(0, 1, 5)
    full = build_image_matrix(f0, f1, times, onnx, depth=3, cells="scaled")
    first, diagonal = np.array([0, 1, 3, 8, 8]), np.array([0, 2, 4, 6, 8])
    pick = np.zeros((5, 9), bool)
    pick[np.arange(5), first] = True
    onnx.pairs = 0
    m = build_image_matrix(f0, f1, times, onnx, depth=3, cells="scaled", wanted=lambda flows: pick)
    assert onnx.pairs == 4  # the rows that move (row 3's frames are the same disc)
    want = pick.copy()
    want[:, [0, 4, 8]] = True
    np.testing.assert_array_equal(m.computed, want)
    onnx.pairs = 0
    done = complete_cells(m, f0, f1, onnx, diagonal)
    assert onnx.pairs == 0
    want[np.arange(5), diagonal] = True
    np.testing.assert_array_equal(done.computed, want)
    # to a half's step below 1 (the cells' precision): the blend of a row's box rounds a few values the other way
    np.testing.assert_allclose(done.frames[want], full.frames[want], atol=2.0**-11)
    np.testing.assert_array_equal(done.masks, m.masks)
    np.testing.assert_array_equal(done.flows, m.flows)


def test_scaled_cells_on_torch_equal_onnx(onnx, rife):
    """The torch runtime's scaled matrix is ONNX Runtime's, to the runtimes' float noise."""
    f0 = disc_frames([30, 36, 40])
    f1 = disc_frames([56, 52, 48])
    times = np.linspace(0, 1, 3)
    a = build_image_matrix(f0, f1, times, onnx, depth=3, cells="scaled")
    b = build_image_matrix(f0, f1, times, rife, depth=3, cells="scaled")
    np.testing.assert_allclose(a.frames, b.frames, atol=2e-3)
    np.testing.assert_allclose(a.masks, b.masks, atol=1e-3)


def test_unknown_cells_are_refused():
    f = random_frames(2)
    with pytest.raises(ValueError, match="cells"):
        build_image_matrix(f, f, np.zeros(2), AveragingFake(), cells="linear")


def test_half_precision_cells_keep_every_8_bit_level(onnx):
    """Scaled cells are stored as float16: within half a half-step of the single-precision blend, so the keys'
    columns give back the drawings' 8-bit levels exactly and every cell's 8-bit frame moves by at most a level."""
    rng = np.random.default_rng(3)
    f0 = np.round(rng.random((3, 32, 48, 4)) * 255).astype(np.float32) / 255
    f1 = np.round(rng.random((3, 32, 48, 4)) * 255).astype(np.float32) / 255
    m = build_image_matrix(f0, f1, np.linspace(0, 1, 3), onnx, depth=2, cells="scaled")
    assert m.frames.dtype == np.float16 and m.flows.dtype == np.float32 and m.masks.dtype == np.float32
    for column, drawing in ((0, f0), (-1, f1)):
        np.testing.assert_array_equal(np.round(m.frames[:, column].astype(np.float32) * 255), np.round(drawing * 255))
    single = build_image_matrix(f0, f1, np.linspace(0, 1, 3), onnx, depth=2, cells="scaled",
                                out=np.zeros(m.frames.shape, np.float16)).frames
    np.testing.assert_array_equal(single, m.frames)  # an `out` of the cells' dtype is filled alike
    with pytest.raises(ValueError, match="float16"):
        build_image_matrix(f0, f1, np.linspace(0, 1, 3), onnx, depth=2, cells="scaled",
                           out=np.zeros(m.frames.shape, np.float32))
