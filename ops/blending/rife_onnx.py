"""RIFE HDv3 midpoints on the CPU without torch: the network's ONNX export run by ONNX Runtime, and the crop,
warp and blend around it in NumPy (§5.2).

The same interface and the same arithmetic as the torch runtime (ops/blending/rife.py, `Rife`): images are
(N, C, H, W) float32 arrays, flows (N, 4, H, W) pixels (channels 0-1 from the middle frame to frame 0, 2-3 to
frame 1), the warp is bilinear with coordinates clamped to the frame (grid_sample's border mode with aligned
corners), the blend premultiplied. Importing torch costs a run 2-2.5 s of CPU, most of it holding the GIL
that the lanes' deformations need (docs/performance.md); with the export cached (`open_export`), a run that
interpolates never imports it.
"""
from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ops.blending.crop import Box, coverage_box, cuts_ink, grow
from ops.blending.rife_files import checked_weights, onnx_file

PAD_MULTIPLE = 32  # as the torch runtime: block0 convolves at 1/16 size
PAPER = np.array([1.0, 1.0, 1.0, 0.0], np.float32).reshape(1, 4, 1, 1)  # a fully transparent midpoint's colour
_threads: int | None = None  # ONNX Runtime's intra-op threads (None: the machine's cores)
_spinning = False  # whether they spin while waiting for work (fastest only when nothing else runs)


def limit_threads(n: int) -> None:
    """How many threads the network uses in this process, whichever runtime runs it (`batch` runs two shots on two
    cores with one each; a farm worker, cores / concurrency): ONNX Runtime's sessions, torch's intra-op threads
    (set now if torch is imported, else through OMP_NUM_THREADS, which torch reads when it is)."""
    global _threads
    _threads = int(n)
    os.environ["OMP_NUM_THREADS"] = str(int(n))
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(int(n))


def set_spinning(spin: bool) -> None:
    """Let ONNX Runtime's threads spin while they wait (off by default: in a run the main thread records the steps
    meanwhile; on for a process that only interpolates, where spinning is 15% faster)."""
    global _spinning
    _spinning = bool(spin)


def pad_to_multiple(x: np.ndarray, multiple: int = PAD_MULTIPLE) -> np.ndarray:
    """Replicate-pad (N, C, H, W) at the bottom/right so H and W are multiples of `multiple` (a black border
    would read as ink on the white page)."""
    h, w = x.shape[2:]
    ph, pw = -h % multiple, -w % multiple
    if ph == 0 and pw == 0:
        return x
    return np.pad(x, ((0, 0), (0, 0), (0, ph), (0, pw)), mode="edge")


def warp(img: np.ndarray, flow: np.ndarray, origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """Backward warp: out(p) = img(origin + p + flow(p)), bilinear, the sample point clamped to the frame;
    img (N, C, H, W), flow (N, 2, h, w) pixels of the (h, w) pixels from `origin` (y, x) on -> (N, C, h, w)
    float32. OpenCV's remap with replicated borders (the clamp): 5x NumPy's gathers."""
    n, c, h, w = img.shape
    fh, fw = flow.shape[2:]
    xs = np.arange(origin[1], origin[1] + fw, dtype=np.float32)[None, :]
    ys = np.arange(origin[0], origin[0] + fh, dtype=np.float32)[:, None]
    out = np.empty((n, c, fh, fw), np.float32)
    for i in range(n):
        map_x = np.ascontiguousarray(xs + flow[i, 0], np.float32)
        map_y = np.ascontiguousarray(ys + flow[i, 1], np.float32)
        c0 = 0
        while c0 < c:  # four channels at a time, the rest one by one (a two-channel remap came back wrong)
            k = 4 if c - c0 >= 4 else 1
            src = np.ascontiguousarray(img[i, c0:c0 + k].transpose(1, 2, 0), np.float32)
            warped = cv2.remap(src, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            out[i, c0:c0 + k] = warped.reshape(fh, fw, k).transpose(2, 0, 1)
            c0 += k
    return out


def over_white(rgba: np.ndarray) -> np.ndarray:
    """(N, 4, H, W) straight alpha -> C-contiguous (N, 3, H, W) RGB composited over a white page."""
    a = rgba[:, 3:4]
    return np.ascontiguousarray(rgba[:, :3] * a + (1 - a), np.float32)


def blend_rgba(a0: np.ndarray, a1: np.ndarray, flow: np.ndarray, mask: np.ndarray,
               origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """Warp and blend (N, 4, H, W) straight RGBA with the network's flow (N, 4, h, w) and mask (N, 1, h, w), the
    weight of a0, of the (h, w) pixels from `origin` (y, x) on (the whole frame by default) -> (N, 4, h, w)
    straight RGBA; premultiplied, so transparent pixels' colours never bleed into edges."""
    pre0 = np.concatenate((a0[:, :3] * a0[:, 3:4], a0[:, 3:4]), 1)
    pre1 = np.concatenate((a1[:, :3] * a1[:, 3:4], a1[:, 3:4]), 1)
    pre = warp(pre0, flow[:, :2], origin) * mask + warp(pre1, flow[:, 2:4], origin) * (1 - mask)
    alpha = pre[:, 3:4]
    rgb = np.where(alpha > 1e-6, pre[:, :3] / np.maximum(alpha, 1e-6), np.float32(1.0))  # no colour: paper
    return np.concatenate((rgb, alpha), 1).astype(np.float32, copy=False)


def scaled_flow_mask(flow, mask, alpha):
    """The midpoint's flows (N, 4, H, W) and fusion mask (N, 1, H, W) moved to `alpha`: the flow to frame 0
    scaled by 2 alpha, to frame 1 by 2 (1 - alpha), as for motion along straight lines at constant speed, and
    the mask's odds weighted by (1 - alpha) / alpha (frame 0's share falls from 1 to 0 as alpha goes 0 -> 1).
    NumPy arrays or torch tensors; alpha a number, or per pixel an array (N, 1, H, W) (NumPy only)."""
    a = alpha if isinstance(alpha, np.ndarray) else float(alpha)
    f = flow * 1.0  # a copy of either array type
    f[:, :2] *= 2.0 * a
    f[:, 2:4] *= 2.0 * (1.0 - a)
    w0 = (1.0 - a) * mask
    return f, w0 / (w0 + a * (1.0 - mask)).clip(1e-6)


def sigmoid(x: np.ndarray) -> np.ndarray:
    return (1.0 / (1.0 + np.exp(-x))).astype(np.float32, copy=False)


class OnnxRife:
    """The RIFE network's ONNX export in an ONNX Runtime session, for midpoint interpolation of host arrays."""

    device = "cpu"
    runtime = "onnxruntime"

    def __init__(self, onnx_path: Path, weights_path: Path):
        self.onnx_path, self.weights_path = Path(onnx_path), Path(weights_path)
        self._sessions: dict[tuple[int, bool], Any] = {}  # (intra-op threads, spinning) -> session
        self._callers = 1  # calls made at once (calls_at_once): each session gets its share of the threads
        self._lock = threading.Lock()

    def concurrency(self) -> int:
        """How many calls are best made at once: one per thread the network may use. Two calls on one thread each
        beat one call on two (0.17 against 0.19-0.21 s a 384² pair on this machine's two cores): a call's small
        convolutions keep two threads only partly busy, and its NumPy warp and blend hold one anyway."""
        return max(1, _threads or os.cpu_count() or 1)

    @contextmanager
    def calls_at_once(self, n: int) -> Iterator[None]:
        """While open, `n` threads call the network at once: each call runs on its share of the threads."""
        self._callers = max(1, int(n))
        try:
            yield
        finally:
            self._callers = 1

    def _session(self) -> Any:
        """The session for the current thread budget (made once per budget, spinning setting included)."""
        threads = max(1, (_threads or os.cpu_count() or 1) // self._callers)
        key = (threads, _spinning and self._callers == 1)
        with self._lock:
            if key not in self._sessions:
                import onnxruntime as ort

                options = ort.SessionOptions()
                options.intra_op_num_threads, options.inter_op_num_threads = threads, 1
                options.log_severity_level = 3  # errors only: its warnings about unused initializers are noise
                # a pipeline's main thread records Dagster's events meanwhile: threads that spin while they wait
                # fight it for the two cores (arm_cross's matrix 8.7 s spinning, 7.2 s not; docs/performance.md)
                options.add_session_config_entry("session.intra_op.allow_spinning", "1" if key[1] else "0")
                self._sessions[key] = ort.InferenceSession(str(self.onnx_path), options,
                                                           providers=["CPUExecutionProvider"])
            return self._sessions[key]

    def _run(self, rgb0: np.ndarray, rgb1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The network on padded (N, 3, H, W) RGB: flow (N, 4, H, W) pixels, mask logits (N, 1, H, W)."""
        flow, logits = self._session().run(None, {"img0": rgb0, "img1": rgb1})  # ONNX Runtime's run is thread-safe
        return flow, logits

    # ---- the cells' array type, as image_matrix builds the matrix on the network's device

    def rgba_tensor(self, img: np.ndarray) -> np.ndarray:
        """(N, H, W, 4) host array -> (N, 4, H, W) float32 (a view)."""
        return np.asarray(img, np.float32).transpose(0, 3, 1, 2)

    @staticmethod
    def empty(shape: tuple[int, ...]) -> np.ndarray:
        return np.empty(shape, np.float32)

    @staticmethod
    def zeros(shape: tuple[int, ...]) -> np.ndarray:
        return np.zeros(shape, np.float32)

    @staticmethod
    def index(ids: np.ndarray) -> np.ndarray:
        return ids

    @staticmethod
    def to_host(cells: np.ndarray) -> np.ndarray:
        """(N, C, H, W) -> (N, H, W, C) float32 host array."""
        return np.ascontiguousarray(cells.transpose(0, 2, 3, 1), np.float32)

    # ---- interpolation

    def forward_rgb(self, img0: np.ndarray, img1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N, 3, H, W) RGB in [0, 1] -> mid (N, 3, H, W), flow (N, 4, H, W) pixels, mask (N, 1, H, W); any H, W."""
        h, w = img0.shape[2:]
        p0 = pad_to_multiple(np.asarray(img0, np.float32))
        p1 = pad_to_multiple(np.asarray(img1, np.float32))
        flow, logits = self._run(np.ascontiguousarray(p0), np.ascontiguousarray(p1))
        mask = sigmoid(logits)
        mid = warp(p0, flow[:, :2]) * mask + warp(p1, flow[:, 2:4]) * (1 - mask)
        crop = (..., slice(0, h), slice(0, w))
        return mid[crop], flow[crop], mask[crop]

    def midpoint(self, img0: np.ndarray, img1: np.ndarray, crop: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(N, H, W, 4) straight RGBA in [0, 1] pair -> mid (N, H, W, 4) float32 in [0, 1], flow (N, H, W, 4)
        float32 pixels; see midpoint_tensors for identical pairs and the crop."""
        if img0.shape != img1.shape or img0.ndim != 4 or img0.shape[3] != 4:
            raise ValueError(f"midpoint expects two (N, H, W, 4) arrays of equal shape, got {img0.shape} and {img1.shape}")
        mid, flow = self.midpoint_tensors(self.rgba_tensor(img0), self.rgba_tensor(img1), crop)
        return self.to_host(mid), self.to_host(flow)

    def midpoint_tensors(self, a0: np.ndarray, a1: np.ndarray, crop: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(N, 4, H, W) straight RGBA -> mid (N, 4, H, W) in [0, 1], flow (N, 4, H, W) pixels.

        A pair of identical images is its own midpoint with zero flow (the network's output for such a pair
        drifts by up to ~0.2 px). With `crop`, the network sees only the box around the ink of the moving pairs
        (ops/blending/crop.py), grown until no ink of the midpoint reaches a cut edge; outside it the midpoint
        is transparent paper and the flow zero."""
        mid, flow, _ = self.midpoint_flow_mask(a0, a1, crop)
        return mid, flow

    def midpoint_flow_mask(self, a0: np.ndarray, a1: np.ndarray,
                           crop: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """midpoint_tensors with the network's fusion mask too: (mid, flow, mask (N, 1, H, W), the weight of a0;
        1/2 where the network did not look: identical pairs, outside the crop)."""
        mid, flow = np.array(a0, np.float32), np.zeros(a0.shape, np.float32)
        mask = np.full((len(a0), 1) + a0.shape[2:], 0.5, np.float32)
        moving = np.nonzero((a0 != a1).reshape(len(a0), -1).any(1))[0]
        if len(moving) == 0:
            return mid, flow, mask
        m0, m1 = a0[moving], a1[moving]
        shape = tuple(a0.shape[2:])
        box = coverage_box(np.concatenate((m0[:, 3], m1[:, 3]))) if crop else Box(0, shape[0], 0, shape[1])
        if box is None:  # no ink in either image: the midpoint of two blank pages
            mid[moving] = PAPER
            return mid, flow, mask
        while True:
            ys, xs = box.slices
            m, f, k = self._net_midpoint(m0[..., ys, xs], m1[..., ys, xs])
            if box.area == shape[0] * shape[1] or not cuts_ink(m[:, 3], box, shape):
                break
            box = grow(box, shape)
        mid[moving] = PAPER
        mid[moving, :, ys, xs] = m
        flow[moving, :, ys, xs] = f
        mask[moving, :, ys, xs] = k
        return mid, flow, mask

    def _net_midpoint(self, a0: np.ndarray, a1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N, 4, h, w) straight RGBA pair, every pair moving -> mid (N, 4, h, w) in [0, 1], flow (N, 4, h, w),
        mask (N, 1, h, w)."""
        h, w = a0.shape[2:]
        p0, p1 = pad_to_multiple(np.asarray(a0, np.float32)), pad_to_multiple(np.asarray(a1, np.float32))
        # flow is estimated on the drawing as seen on paper: ink composited over white
        flow, logits = self._run(over_white(p0), over_white(p1))
        mask = sigmoid(logits)
        mid = blend_rgba(p0, p1, flow, mask)
        return np.clip(mid[..., :h, :w], 0.0, 1.0), flow[..., :h, :w], mask[..., :h, :w]

    @staticmethod
    def blend_at(a0: np.ndarray, a1: np.ndarray, flow: np.ndarray, mask: np.ndarray,
                 alpha: float | np.ndarray, region: Box | None = None) -> np.ndarray:
        """The frame at `alpha` of (N, 4, H, W) straight RGBA pairs from their midpoint's flow (N, 4, H, W) and
        mask (N, 1, H, W) (midpoint_flow_mask), the flows scaled linearly -> (N, 4, H, W) in [0, 1]; alpha 1/2
        gives the midpoint, 0 and 1 the pair's own images (ops/blending/image_matrix.py, scaled cells); alpha a
        number or per pixel (N, 1, H, W) (ops/blending/local_alpha.py). region: only its pixels, (N, 4, h, w),
        each as in the whole frame (a pixel's blend reads its own flow, mask and alpha alone)."""
        a0, a1 = np.asarray(a0, np.float32), np.asarray(a1, np.float32)
        region = Box(0, a0.shape[2], 0, a0.shape[3]) if region is None else region
        out = np.broadcast_to(PAPER, (*a0.shape[:2], region.y1 - region.y0, region.x1 - region.x0)).copy()
        # outside the box around both images' coverage and the flows every sample is transparent: paper
        box = coverage_box(np.concatenate((a0[:, 3], a1[:, 3], (flow != 0).any(1))), margin=2, grid=1)
        inner = None if box is None else Box(max(box.y0, region.y0), min(box.y1, region.y1),
                                             max(box.x0, region.x0), min(box.x1, region.x1))
        if inner is not None and inner.y0 < inner.y1 and inner.x0 < inner.x1:
            ys, xs = box.slices
            iy, ix = inner.slices
            a = alpha[..., iy, ix] if isinstance(alpha, np.ndarray) else alpha
            f, m = scaled_flow_mask(flow[..., iy, ix], mask[..., iy, ix], a)
            blend = blend_rgba(a0[..., ys, xs], a1[..., ys, xs], f, m, (inner.y0 - box.y0, inner.x0 - box.x0))
            out[..., inner.y0 - region.y0:inner.y1 - region.y0, inner.x0 - region.x0:inner.x1 - region.x0] = \
                np.clip(blend, 0.0, 1.0)
        same = ~(a0 != a1).reshape(len(a0), -1).any(1)  # an identical pair is its own frame at every alpha
        out[same] = a0[same][..., region.y0:region.y1, region.x0:region.x1]
        return out


def open_export(weights_path: str | Path | None, cache_dir: str | Path) -> OnnxRife | None:
    """The network's cached ONNX export for these weights (checked as load_rife checks them), or None when it has
    not been exported yet (ops/blending/rife.py load_rife exports it) or onnxruntime is missing."""
    path, digest = checked_weights(weights_path)
    target = onnx_file(cache_dir, digest)
    if not target.is_file():
        return None
    try:
        import onnxruntime  # noqa: F401  (only whether it is there)
    except ImportError:
        return None
    return OnnxRife(target, path)

