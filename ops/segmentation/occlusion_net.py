"""A small U-Net that reads occlusion from a drawing and its skeleton (§4.1), in torch: for training.

The paper predicts occlusion masks with a U-Net on a DINOv2 backbone whose weights are not public; this one
is trained from scratch on the generated characters of data_samples/ (tools/train_occlusion.py, fixed seed)
and is small enough for the CPU: it works at half resolution and only its last layer sees every pixel.

Input: (N, IN_CHANNELS, H, W) float32, H and W multiples of STRIDE: 3 colour channels (the drawing minus its
paper colour, in [-1, 1]) and the skeleton channels of ops.segmentation.skeleton_guide. Output: (N, 1, H, W)
float32 logits of "this pixel shows a part that covers another part" (the union of the occlusion masks,
joint overlaps included).
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

# the architecture's sizes and the weights file live with the NumPy forward pass (inference needs no torch)
from ops.segmentation.occlusion_infer import (  # noqa: F401  (re-exported for training and tests)
    HEAD_WIDTH,
    IN_CHANNELS,
    STRIDE,
    WEIGHTS_PATH,
    WEIGHTS_SHA256,
    WIDTHS,
    check_weights,
    file_sha256,
)
from ops.shotio.npz import read_npz


def conv_bn_relu(cin: int, cout: int, k: int = 3, stride: int = 1, dilation: int = 1) -> nn.Sequential:
    """Conv -> BatchNorm -> ReLU, 'same' padding for stride 1."""
    pad = dilation * (k - 1) // 2 if stride == 1 else (k - 1) // 2
    return nn.Sequential(nn.Conv2d(cin, cout, k, stride, pad, dilation=dilation, bias=False), nn.BatchNorm2d(cout),
                         nn.ReLU(inplace=True))


class UNetTrunk(nn.Module):
    """The encoder at 1/2 .. 1/16 resolution and the decoder back to 1/2 that both networks share (this one and
    ops.segmentation.junction_net's); each adds its own head at full resolution. The levels keep the names e1 ..
    e4, d3 .. d1, which the weights files and the NumPy forward passes read."""

    def build_trunk(self, c_in: int, widths: tuple[int, int, int, int], first_kernel: int, out_width: int) -> None:
        """Add the levels for c_in input channels; the first halves the resolution with a first_kernel convolution,
        the decoder ends with out_width channels at 1/2."""
        w1, w2, w3, w4 = widths
        self.e1 = nn.Sequential(conv_bn_relu(c_in, w1, first_kernel, 2), conv_bn_relu(w1, w1))
        self.e2 = nn.Sequential(conv_bn_relu(w1, w2, 3, 2), conv_bn_relu(w2, w2))
        self.e3 = nn.Sequential(conv_bn_relu(w2, w3, 3, 2), conv_bn_relu(w3, w3))
        # dilated convolutions at 1/16 see a round belly whole
        self.e4 = nn.Sequential(conv_bn_relu(w3, w4, 3, 2), conv_bn_relu(w4, w4, dilation=2), conv_bn_relu(w4, w4, dilation=4))
        self.d3 = conv_bn_relu(w4 + w3, w3)
        self.d2 = conv_bn_relu(w3 + w2, w2)
        self.d1 = conv_bn_relu(w2 + w1, out_width)

    def trunk(self, x: torch.Tensor) -> torch.Tensor:
        """(N, c_in, H, W) -> the decoder's (N, out_width, H, W), upsampled to the input's resolution."""
        e1 = self.e1(x)
        e2 = self.e2(e1)
        e3 = self.e3(e2)
        e4 = self.e4(e3)
        d3 = self.d3(torch.cat([_up(e4, e3), e3], 1))
        d2 = self.d2(torch.cat([_up(d3, e2), e2], 1))
        return _up(self.d1(torch.cat([_up(d2, e1), e1], 1)), x)


def _up(t: torch.Tensor, ref: torch.Tensor) -> torch.Tensor:
    """t bilinearly resized to ref's height and width."""
    return F.interpolate(t, size=ref.shape[-2:], mode="bilinear", align_corners=False)


class OcclusionUNet(UNetTrunk):
    """Encoder at 1/2 .. 1/16 resolution, decoder back to 1/2, a per-pixel head at full resolution."""

    def __init__(self, widths: tuple[int, int, int, int] = WIDTHS):
        super().__init__()
        self.build_trunk(IN_CHANNELS, widths, 4, HEAD_WIDTH)
        self.head = nn.Sequential(nn.Conv2d(HEAD_WIDTH + IN_CHANNELS, 16, 1), nn.ReLU(inplace=True),
                                  nn.Conv2d(16, 1, 3, 1, 1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(torch.cat([self.trunk(x), x], 1))


def save_weights(net: nn.Module, path: Path) -> str:
    """Write a network's state as float32 arrays in an .npz (no pickle); returns the file's sha256. Both networks
    (this one and ops.segmentation.junction_net's) are stored so."""
    state = {k: v.detach().cpu().numpy().astype(np.float32) for k, v in net.state_dict().items()
             if v.dtype.is_floating_point}
    np.savez_compressed(path, **state)
    return file_sha256(path)


def load_state(net: nn.Module, path: Path) -> nn.Module:
    """`net` with the state a save_weights file holds (checked by the caller), in eval mode."""
    state = {k: torch.from_numpy(v) for k, v in read_npz(path).items()}
    for k, v in net.state_dict().items():  # BatchNorm's integer step counters are not stored
        if k not in state and not v.dtype.is_floating_point:
            state[k] = v
    net.load_state_dict(state)
    net.eval()
    return net


@lru_cache(maxsize=2)
def load_network(path: str = str(WEIGHTS_PATH), sha256: str = WEIGHTS_SHA256) -> OcclusionUNet:
    """The trained network in eval mode, after checking the weights file's sha256 (shipped in the repository)."""
    check_weights(Path(path), sha256)
    return load_state(OcclusionUNet(), Path(path))
