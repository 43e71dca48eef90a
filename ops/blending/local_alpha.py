"""Per-pixel alpha: each frame's alpha moved, pixel by pixel, toward the lane whose texture is reliable there.

The path (§5.2) picks one alpha per frame, weighing among other things q(t, alpha) = (1 - alpha) s0 + alpha s1,
the lanes' visible unreliable shares (texture inpainted or torn). Where one lane's frame is unreliable in a part
of the picture and the other's is not (a belly the lifted arm uncovers is inpainted in the lane of the key where
the arm covered it and drawn in the other), the frame is better taken from the other lane there. Per pixel, the
cost (1 - a) u0(x) + a u1(x) + (a - alpha)^2 / (2 strength), u the lanes' unreliable masks blurred over SIGMA px,
is least at

    a(x) = clip(alpha + strength (u0(x) - u1(x)), 0, 1):

the frame's alpha wherever the lanes are alike, and smooth, so the scaled flows (ops/blending/rife_onnx.py
scaled_flow_mask, with a per-pixel alpha) carry each pixel to a nearby time. The segment's first and last frames
keep their alpha (the keys come back exact).
"""
from __future__ import annotations

import cv2
import numpy as np

from ops.blending.crop import Box
from ops.blending.quality import unreliable_pixels
from ops.blending.rife_onnx import OnnxRife
from ops.types import DeformedSequence, ImageMatrix

SIGMA = 3.0  # px: how far a lane's unreliable texture reaches into its neighbourhood's alpha


def alpha_shift(unreliable0: np.ndarray, unreliable1: np.ndarray, strength: float, sigma: float = SIGMA
                ) -> np.ndarray:
    """(H, W) float32 strength (u0 - u1), u the (H, W) bool unreliable masks of lane 0 and lane 1 blurred over
    sigma px (the kernel cut at 3 sigma): how far each pixel's alpha moves, before clipping, at any alpha."""
    size = 2 * int(np.ceil(3 * sigma)) + 1
    u0 = cv2.GaussianBlur(unreliable0.astype(np.float32), (size, size), sigma)
    u1 = cv2.GaussianBlur(unreliable1.astype(np.float32), (size, size), sigma)
    return np.float32(strength) * (u0 - u1)


def shifted_alpha(alpha: float, shift: np.ndarray) -> np.ndarray:
    """(H, W) float32 alpha per pixel: `alpha` moved by an (H, W) alpha_shift, clipped to [0, 1]."""
    return np.clip(np.float32(alpha) + shift, 0.0, 1.0).astype(np.float32)


def local_alpha(alpha: float, unreliable0: np.ndarray, unreliable1: np.ndarray, strength: float,
                sigma: float = SIGMA) -> np.ndarray:
    """(H, W) float32 alpha per pixel: `alpha` moved by alpha_shift (further than 3 sigma from unreliable texture
    alpha is exactly `alpha`), clipped to [0, 1]."""
    return shifted_alpha(alpha, alpha_shift(unreliable0, unreliable1, strength, sigma))


def local_frames(frames: np.ndarray, seq0: DeformedSequence, seq1: DeformedSequence, matrix: ImageMatrix,
                 alphas: np.ndarray, strength: float) -> tuple[np.ndarray, np.ndarray]:
    """The path's frames (T, H, W, 4) with every interior frame blended at its per-pixel alpha from its row's
    alpha-1/2 flows and mask (a scaled matrix's); alphas (T,) the path's. Returns the frames and, per frame, the
    share (T,) of its pixels whose alpha moved by more than 1/16."""
    if matrix.masks is None:
        raise ValueError("per-pixel alpha needs a scaled matrix (Settings.matrix_cells 'scaled'): it keeps the masks")
    out = np.array(frames, np.float32)
    moved = np.zeros(len(frames))
    u0, u1 = unreliable_pixels(seq0), unreliable_pixels(seq1)  # what q counts
    for t in range(1, len(frames) - 1):
        a = local_alpha(float(alphas[t]), u0[t], u1[t], strength)
        changed = a != np.float32(alphas[t])
        if not changed.any():
            continue
        moved[t] = (np.abs(a - alphas[t]) > 1.0 / 16).mean()
        # a pixel's blend reads only its own alpha: the path's cell stands wherever alpha did not move
        rows, cols = np.nonzero(changed.any(1))[0], np.nonzero(changed.any(0))[0]
        region = Box(int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1)
        pair = [np.asarray(s.images[t], np.float32).transpose(2, 0, 1)[None] for s in (seq0, seq1)]
        flow = np.asarray(matrix.flows[t], np.float32).transpose(2, 0, 1)[None]
        mask = np.asarray(matrix.masks[t], np.float32)[None, None]
        blend = OnnxRife.blend_at(pair[0], pair[1], flow, mask, a[None, None], region)[0].transpose(1, 2, 0)
        ys, xs = region.slices
        out[t, ys, xs] = np.where(changed[ys, xs, None], blend, out[t, ys, xs])
    return out, moved
