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
from ops.segmentation.occlusion_net import UNetTrunk, load_state, save_weights  # noqa: F401  (save_weights: for training)
from ops.segmentation.occlusion_net import conv_bn_relu as _conv

HEAT_PRIOR = 1e-3  # the heat logit's initial bias: about one pixel in a thousand is a junction


class JunctionUNet(UNetTrunk):
    """Full-resolution stem, encoder at 1/2 .. 1/16, decoder back to 1/2, a head at full resolution."""

    def __init__(self, widths: tuple[int, int, int, int] = WIDTHS):
        super().__init__()
        self.stem = _conv(IN_CHANNELS, STEM_WIDTH)
        self.build_trunk(IN_CHANNELS, widths, 3, DECODER_WIDTH)
        self.head = _conv(DECODER_WIDTH + STEM_WIDTH, HEAD_WIDTH)
        self.out = nn.Conv2d(HEAD_WIDTH, OUT_CHANNELS, 1)
        with torch.no_grad():
            self.out.bias.zero_()
            self.out.bias[0] = float(np.log(HEAT_PRIOR / (1 - HEAT_PRIOR)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(self.head(torch.cat([self.trunk(x), self.stem(x)], 1)))


@lru_cache(maxsize=2)
def load_network(path: str = str(WEIGHTS_PATH), sha256: str = WEIGHTS_SHA256) -> JunctionUNet:
    """The trained network in eval mode, after checking the weights file's sha256."""
    check_weights(Path(path), sha256)
    return load_state(JunctionUNet(), Path(path))
