"""The T-junction network's input and forward pass in NumPy (§4.1): inference without torch.

ops.segmentation.junction_net defines the network in torch, for training (tools/train_junctions.py); this
module runs the same layers on the same weights file (a test compares the two), so the stages that propose
junctions never import torch. Convolutions are ops.segmentation.occlusion_infer's im2col ones.

The network reads a keyframe as the occlusion network does (ops.segmentation.network_input: the drawing
minus its paper colour, and the skeleton channels of ops.segmentation.skeleton_guide), cropped to the
character and scaled so that the joints' box is JUNCTION_EXTENT_PX on its longer side (about the generators'
own scale: junctions lie a few pixels apart, finer than the occlusion network's 128 px frame shows).

Architecture: a full-resolution stem; an encoder at 1/2 to 1/16 (dilated at 1/16); a decoder back to 1/2; a
head at full resolution on the stem and the decoder. Outputs per pixel: the logit of "a T-junction lies at
this pixel" (a heatmap whose peaks are the junctions) and the stem's direction there (cos, sin, before
normalisation).

Input: (IN_CHANNELS, H, W) float32, H and W multiples of STRIDE. Output: (OUT_CHANNELS, H, W) float32.
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from ops.segmentation.network_input import WorkFrame, colour_channels, paper_colour, resample, to_work, work_frame
from ops.segmentation.occlusion_infer import (  # file_sha256: re-exported for training
    _fold,
    _relu,
    _up,
    conv2d,
    file_sha256,  # noqa: F401
    plain_conv,
    read_weights,
)
from ops.segmentation.occlusion_infer import check_weights as _check_weights
from ops.segmentation.skeleton_guide import GUIDE_CHANNELS, guide_channels
from ops.types import Skeleton

IN_CHANNELS = 3 + GUIDE_CHANNELS
OUT_CHANNELS = 3  # heat logit, stem cos, stem sin
STRIDE = 16
STEM_WIDTH = 12  # full-resolution features
WIDTHS = (16, 24, 32, 48)
DECODER_WIDTH = 16  # the decoder's last width, at 1/2
HEAD_WIDTH = 16
JUNCTION_EXTENT_PX = 160.0  # longer side of the joints' box at the network's scale (the generators' median)
MAX_ZOOM = 4.0
WEIGHTS_PATH = Path(__file__).with_name("junction_unet.npz")
# sha256 of WEIGHTS_PATH: a retrained network changes this module, hence the code version of the stages using it
WEIGHTS_SHA256 = "c2818860793c4e109b573b495701634acf626e809c4bdbeb3755131b4f9e53cf"

# (name in the weights file, stride, padding, dilation) of each conv + BatchNorm + ReLU, in forward order
ENCODER = {
    "e1": [("e1.0", 2, 1, 1), ("e1.1", 1, 1, 1)],
    "e2": [("e2.0", 2, 1, 1), ("e2.1", 1, 1, 1)],
    "e3": [("e3.0", 2, 1, 1), ("e3.1", 1, 1, 1)],
    "e4": [("e4.0", 2, 1, 1), ("e4.1", 1, 2, 2), ("e4.2", 1, 4, 4)],
}
BN_LAYERS = ("stem",) + tuple(n for block in ENCODER.values() for n, *_ in block) + ("d3", "d2", "d1", "head")


def check_weights(path: Path, sha256: str) -> None:
    """FileNotFoundError or ValueError (one line with its fix) unless `path` holds the expected weights."""
    _check_weights(path, sha256, "T-junction", "tools/train_junctions.py",
                   "restore the file from the repository or run tools/train_junctions.py")


@lru_cache(maxsize=2)
def folded_weights(path: str = str(WEIGHTS_PATH), sha256: str = WEIGHTS_SHA256) -> dict[str, tuple]:
    """{layer: ((O, C*k*k) float32 weights, (O,) float32 bias, k)} with each BatchNorm folded into its conv."""
    check_weights(Path(path), sha256)
    raw = read_weights(path)
    layers = {name: _fold(raw[f"{name}.0.weight"], raw, f"{name}.1") for name in BN_LAYERS}
    layers["out"] = plain_conv(raw, "out")
    return layers


def junction_outputs(x: np.ndarray, path: str | None = None, sha256: str | None = None) -> np.ndarray:
    """(IN_CHANNELS, H, W) float32 network input -> (OUT_CHANNELS, H, W) float32: heat logit, stem (cos, sin).

    path, sha256: the weights (default WEIGHTS_PATH and WEIGHTS_SHA256 as they are at the call)."""
    if x.ndim != 3 or x.shape[0] != IN_CHANNELS or x.shape[1] % STRIDE or x.shape[2] % STRIDE:
        raise ValueError(f"junction network input must be ({IN_CHANNELS}, H, W) with H, W multiples of {STRIDE}, "
                         f"got {x.shape}")
    layers = folded_weights(str(WEIGHTS_PATH) if path is None else path, WEIGHTS_SHA256 if sha256 is None else sha256)
    x = np.ascontiguousarray(x, np.float32)
    stem = _relu(conv2d(x, layers["stem"], pad=1))
    skips, t = [], x
    for block in ENCODER.values():
        for name, stride, pad, dilation in block:
            t = _relu(conv2d(t, layers[name], stride, pad, dilation))
        skips.append(t)
    e1, e2, e3, e4 = skips
    d3 = _relu(conv2d(np.concatenate([_up(e4, e3.shape[1:]), e3]), layers["d3"], pad=1))
    d2 = _relu(conv2d(np.concatenate([_up(d3, e2.shape[1:]), e2]), layers["d2"], pad=1))
    d1 = _relu(conv2d(np.concatenate([_up(d2, e1.shape[1:]), e1]), layers["d1"], pad=1))
    h = _relu(conv2d(np.concatenate([_up(d1, x.shape[1:]), stem]), layers["head"], pad=1))
    return conv2d(h, layers["out"])


def junction_frame(foreground: np.ndarray, pose: np.ndarray) -> WorkFrame:
    """The crop around the (H, W) bool foreground and the joints, at the junction network's zoom."""
    frame = work_frame(foreground, pose)
    xy = pose[:, :2]
    extent = float(np.max(xy.max(0) - xy.min(0))) if len(xy) else 0.0
    frame.zoom = float(np.clip(JUNCTION_EXTENT_PX / max(extent, 1.0), 1.0 / MAX_ZOOM, MAX_ZOOM))
    return frame


def junction_input(image: np.ndarray, frame: WorkFrame, pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(IN_CHANNELS, h, w) float32 network input of a (H, W, 3) uint8 drawing in `frame`, padded to multiples
    of STRIDE (padding reads as paper); pose: (J, 3) keyframe pixels and depth."""
    x0, y0, x1, y1 = frame.box
    hw = frame.work_shape()
    crop = resample(np.ascontiguousarray(image[y0:y1, x0:x1]), hw)
    ph, pw = (-(-s // STRIDE) * STRIDE for s in hw)
    colour = np.zeros((3, ph, pw), np.float32)
    colour[:, : hw[0], : hw[1]] = colour_channels(crop, paper_colour(image))
    return np.concatenate([colour, guide_channels(to_work(pose, frame), skeleton, (ph, pw))])


def to_keyframe(points: np.ndarray, frame: WorkFrame) -> np.ndarray:
    """(k, 2) keyframe pixels of (k, 2) x, y working pixels (the inverse of network_input.to_work)."""
    x0, y0, x1, y1 = frame.box
    h, w = frame.work_shape()
    out = np.array(points, np.float64, copy=True).reshape(-1, 2)
    out[:, 0] = (out[:, 0] + 0.5) * ((x1 - x0) / w) - 0.5 + x0
    out[:, 1] = (out[:, 1] + 0.5) * ((y1 - y0) / h) - 0.5 + y0
    return out
