"""A small U-Net that finds T-junctions in a drawing with its skeleton as a guide (§4.1), in torch: for training.

Trained from scratch on the generators' exact junctions (tools/train_junctions.py); inference runs the same
layers in NumPy (ops.segmentation.junction_infer), whose module holds the sizes and the weights file.

Input: (N, IN_CHANNELS, H, W) float32, H and W multiples of STRIDE. Output: (N, OUT_CHANNELS, H, W) float32:
the heat logit and the stem's (cos, sin).
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from ops.segmentation.junction_infer import (  # noqa: F401  (re-exported for training and tests)
    DECODER_WIDTH,
    HEAD_WIDTH,
    IN_CHANNELS,
    OUT_CHANNELS,
    STEM_WIDTH,
    STRIDE,
    WEIGHTS_PATH,
    WEIGHTS_SHA256,
    WIDTHS,
    check_weights,
)
from ops.segmentation.occlusion_net import conv_bn_relu as _conv
from ops.segmentation.occlusion_net import load_state, save_weights  # noqa: F401  (save_weights: for training)

HEAT_PRIOR = 1e-3  # the heat logit's initial bias: about one pixel in a thousand is a junction


class JunctionUNet(nn.Module):
    """Full-resolution stem, encoder at 1/2 .. 1/16, decoder back to 1/2, a head at full resolution."""

    def __init__(self, widths: tuple[int, int, int, int] = WIDTHS):
        super().__init__()
        w1, w2, w3, w4 = widths
        self.stem = _conv(IN_CHANNELS, STEM_WIDTH)
        self.e1 = nn.Sequential(_conv(IN_CHANNELS, w1, 3, 2), _conv(w1, w1))
        self.e2 = nn.Sequential(_conv(w1, w2, 3, 2), _conv(w2, w2))
        self.e3 = nn.Sequential(_conv(w2, w3, 3, 2), _conv(w3, w3))
        self.e4 = nn.Sequential(_conv(w3, w4, 3, 2), _conv(w4, w4, dilation=2), _conv(w4, w4, dilation=4))
        self.d3 = _conv(w4 + w3, w3)
        self.d2 = _conv(w3 + w2, w2)
        self.d1 = _conv(w2 + w1, DECODER_WIDTH)
        self.head = _conv(DECODER_WIDTH + STEM_WIDTH, HEAD_WIDTH)
        self.out = nn.Conv2d(HEAD_WIDTH, OUT_CHANNELS, 1)
        with torch.no_grad():
            self.out.bias.zero_()
            self.out.bias[0] = float(np.log(HEAT_PRIOR / (1 - HEAT_PRIOR)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        stem = self.stem(x)
        e1 = self.e1(x)
        e2 = self.e2(e1)
        e3 = self.e3(e2)
        e4 = self.e4(e3)
        up = lambda t, ref: F.interpolate(t, size=ref.shape[-2:], mode="bilinear", align_corners=False)  # noqa: E731
        d3 = self.d3(torch.cat([up(e4, e3), e3], 1))
        d2 = self.d2(torch.cat([up(d3, e2), e2], 1))
        d1 = self.d1(torch.cat([up(d2, e1), e1], 1))
        return self.out(self.head(torch.cat([up(d1, x), stem], 1)))


@lru_cache(maxsize=2)
def load_network(path: str = str(WEIGHTS_PATH), sha256: str = WEIGHTS_SHA256) -> JunctionUNet:
    """The trained network in eval mode, after checking the weights file's sha256."""
    check_weights(Path(path), sha256)
    return load_state(JunctionUNet(), Path(path))
