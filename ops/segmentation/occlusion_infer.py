"""The shipped occlusion network's forward pass in NumPy: inference without torch.

ops.segmentation.occlusion_net defines the network in torch, for training; this module runs the same layers
on the same weights file (tests compare the two). The masks stages then never import torch: both keyframe
lanes used to wait on one torch import (1-1.5 s of a cold run) in the middle of their masks stage, and the
import now happens only where RIFE needs it. The network works at the characters' working scale (about
WORK_EXTENT_PX across, ops.segmentation.network_input), so plain im2col convolutions cost a few milliseconds.

BatchNorm with its stored statistics (eval mode) is folded into the convolution before it, once, when the
weights are loaded.

Input: (IN_CHANNELS, H, W) float32, H and W multiples of STRIDE. Output: (H, W) float32 logits.
"""
from __future__ import annotations

import hashlib
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np

from ops.segmentation.skeleton_guide import GUIDE_CHANNELS
from ops.shotio.npz import read_npz

IN_CHANNELS = 3 + GUIDE_CHANNELS
STRIDE = 16  # the input's sides must be multiples of this (four halvings)
WIDTHS = (16, 24, 32, 48)
HEAD_WIDTH = 12
BN_EPS = 1e-5  # torch.nn.BatchNorm2d's default
WEIGHTS_PATH = Path(__file__).with_name("occlusion_unet.npz")
# sha256 of WEIGHTS_PATH: a retrained network changes this module, hence the code version of the stages using it
WEIGHTS_SHA256 = "70fab8ba16e75c28dbe97a0fda25c506b0988482be404301ac5407789482e615"

# (name in the weights file, stride, padding, dilation) of each conv + BatchNorm + ReLU, in forward order
_ENCODER = {
    "e1": [("e1.0", 2, 1, 1), ("e1.1", 1, 1, 1)],
    "e2": [("e2.0", 2, 1, 1), ("e2.1", 1, 1, 1)],
    "e3": [("e3.0", 2, 1, 1), ("e3.1", 1, 1, 1)],
    "e4": [("e4.0", 2, 1, 1), ("e4.1", 1, 2, 2), ("e4.2", 1, 4, 4)],  # dilated: a round belly seen whole
}


def file_sha256(path: Path) -> str:
    """Hex sha256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def check_weights(path: Path, sha256: str, network: str = "occlusion", trainer: str = "tools/train_occlusion.py",
                  missing_fix: str = "run tools/train_occlusion.py or use settings occlusion='skeleton'") -> None:
    """FileNotFoundError or ValueError (one line with its fix) unless `path` holds the expected weights of the
    named network (retrained by `trainer`)."""
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p}: {network} network weights missing; fix: {missing_fix}")
    digest = file_sha256(p)
    if sha256 and digest != sha256:
        raise ValueError(f"{p}: sha256 {digest} differs from the expected {sha256}; fix: restore the file from the "
                         f"repository or retrain with {trainer} (it updates WEIGHTS_SHA256)")


def read_weights(path: str | Path) -> dict[str, np.ndarray]:
    """Every array of a weights .npz (no pickle), as float64 (the folding's precision)."""
    return {k: v.astype(np.float64) for k, v in read_npz(path).items()}


def plain_conv(raw: dict, name: str) -> tuple[np.ndarray, np.ndarray, int]:
    """A conv with a bias and no BatchNorm, as a folded layer: (O, C*k*k) float32 weights, (O,) bias, k."""
    w = raw[f"{name}.weight"]
    return w.reshape(len(w), -1).astype(np.float32), raw[f"{name}.bias"].astype(np.float32), w.shape[-1]


@lru_cache(maxsize=2)
def folded_weights(path: str = str(WEIGHTS_PATH), sha256: str = WEIGHTS_SHA256) -> dict[str, tuple]:
    """{layer: ((O, C*k*k) float32 weights, (O,) float32 bias, k)} with each BatchNorm folded into its conv."""
    check_weights(Path(path), sha256)
    raw = read_weights(path)
    layers: dict[str, tuple] = {}
    for name in [n for block in _ENCODER.values() for n, *_ in block]:
        layers[name] = _fold(raw[f"{name}.0.weight"], raw, f"{name}.1")
    for name in ("d3", "d2", "d1"):  # _conv directly: conv "d3.0", BatchNorm "d3.1"
        layers[name] = _fold(raw[f"{name}.0.weight"], raw, f"{name}.1")
    for name in ("head.0", "head.2"):
        layers[name] = plain_conv(raw, name)
    return layers


def _fold(w: np.ndarray, raw: dict, bn: str) -> tuple[np.ndarray, np.ndarray, int]:
    """Conv weights (O, C, k, k) followed by BatchNorm `bn` -> one conv's (O, C*k*k) weights, (O,) bias, k."""
    scale = raw[f"{bn}.weight"] / np.sqrt(raw[f"{bn}.running_var"] + BN_EPS)
    bias = raw[f"{bn}.bias"] - raw[f"{bn}.running_mean"] * scale
    return (w * scale[:, None, None, None]).reshape(len(w), -1).astype(np.float32), bias.astype(np.float32), w.shape[-1]


def conv2d(x: np.ndarray, layer: tuple, stride: int = 1, pad: int = 0, dilation: int = 1) -> np.ndarray:
    """Cross-correlation of x (C, H, W) with a folded layer, zero padding -> (O, Ho, Wo) float32."""
    w, b, k = layer
    c, h, wd = x.shape
    span = dilation * (k - 1) + 1
    ho, wo = (h + 2 * pad - span) // stride + 1, (wd + 2 * pad - span) // stride + 1
    xp = np.pad(x, ((0, 0), (pad, pad), (pad, pad))) if pad else x
    cols = np.empty((c, k, k, ho, wo), np.float32)  # im2col, ordered as the weights' (C, k, k)
    for i in range(k):
        for j in range(k):
            y0, x0 = i * dilation, j * dilation
            cols[:, i, j] = xp[:, y0:y0 + stride * (ho - 1) + 1:stride, x0:x0 + stride * (wo - 1) + 1:stride]
    return (w @ cols.reshape(c * k * k, ho * wo) + b[:, None]).reshape(len(w), ho, wo)


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0, out=x)


def _up(x: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Bilinear resize of (C, H, W) to (C, *shape), half-pixel centres (torch's align_corners=False)."""
    if x.shape[1:] == shape:
        return x
    hwc = cv2.resize(np.ascontiguousarray(x.transpose(1, 2, 0)), (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR)
    return hwc.reshape(shape[0], shape[1], -1).transpose(2, 0, 1)


def occlusion_logits(x: np.ndarray, path: str | None = None, sha256: str | None = None) -> np.ndarray:
    """(IN_CHANNELS, H, W) float32 network input -> (H, W) float32 logits of "this pixel covers another part".

    path, sha256: the weights (default: WEIGHTS_PATH and WEIGHTS_SHA256 as they are at the call, so a tool
    that evaluates a candidate weights file sets both)."""
    if x.ndim != 3 or x.shape[0] != IN_CHANNELS or x.shape[1] % STRIDE or x.shape[2] % STRIDE:
        raise ValueError(f"occlusion network input must be ({IN_CHANNELS}, H, W) with H, W multiples of {STRIDE}, "
                         f"got {x.shape}")
    layers = folded_weights(str(WEIGHTS_PATH) if path is None else path, WEIGHTS_SHA256 if sha256 is None else sha256)
    x = np.ascontiguousarray(x, np.float32)
    skips, t = [], x
    for block in _ENCODER.values():
        for name, stride, pad, dilation in block:
            t = _relu(conv2d(t, layers[name], stride, pad, dilation))
        skips.append(t)
    e1, e2, e3, e4 = skips
    d3 = _relu(conv2d(np.concatenate([_up(e4, e3.shape[1:]), e3]), layers["d3"], pad=1))
    d2 = _relu(conv2d(np.concatenate([_up(d3, e2.shape[1:]), e2]), layers["d2"], pad=1))
    d1 = _relu(conv2d(np.concatenate([_up(d2, e1.shape[1:]), e1]), layers["d1"], pad=1))
    h = _relu(conv2d(np.concatenate([_up(d1, x.shape[1:]), x]), layers["head.0"]))
    return conv2d(h, layers["head.2"], pad=1)[0]
