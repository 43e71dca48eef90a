"""Evaluation metrics against ground-truth frames: PSNR, SSIM, Chamfer distance of the ink.

Images are float32 in [0, 1]. SSIM and the ink mask work on luminance
(Rec. 709 weights) after compositing straight-alpha RGBA over a white page,
since line drawings are judged as they would be printed.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt
from skimage.metrics import structural_similarity

from ops.evaluation.psnr import psnr  # noqa: F401  (one of this module's metrics; its own module for the lanes)
from ops.shotio.image_io import composite_over_white

LUMA = np.array([0.2126, 0.7152, 0.0722], dtype=np.float64)  # Rec. 709
CHAMFER_SCALE = 1e5  # Chamfer is reported in units of 1e-5 image diagonals


def luminance(image: np.ndarray) -> np.ndarray:
    """(H, W), (H, W, 1|3|4) in [0, 1] -> (H, W) float64 luminance; RGBA composited over white."""
    img = np.asarray(image, dtype=np.float64)
    if img.ndim == 2:
        return img
    c = img.shape[2]
    if c == 4:
        img = composite_over_white(img)
    elif c == 2:  # grey + alpha
        return img[..., 0] * img[..., 1] + (1.0 - img[..., 1])
    if img.shape[2] == 1:
        return img[..., 0]
    return img[..., :3] @ LUMA


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """a, b: same-shape images in [0, 1] -> SSIM of their luminance (data_range 1)."""
    la, lb = luminance(a), luminance(b)
    if la.shape != lb.shape:
        raise ValueError(f"ssim needs equal shapes, got {la.shape} and {lb.shape}")
    return float(structural_similarity(la, lb, data_range=1.0))


INK_LUMINANCE = 0.5  # ink is darker than this over white, unless the drawing has (almost) none that dark
MIN_INK_SHARE = 1e-3  # a reference with less of its pixels that dark is drawn in pale lines (ink_threshold)


def ink_threshold(reference: np.ndarray) -> float:
    """The luminance under which a pixel is ink when comparing with `reference` (an image, as ink_mask takes):
    INK_LUMINANCE, unless under MIN_INK_SHARE of the reference's pixels are that dark (pale blue lines, crayon:
    the 0.5 rule finds no ink there, and Chamfer would compare an empty set with a few specks); then half way
    between its darkest 1 % and its median (the paper)."""
    L = luminance(reference)
    if (L < INK_LUMINANCE).mean() >= MIN_INK_SHARE:
        return INK_LUMINANCE
    dark, paper = np.percentile(L, [1, 50])
    return float((dark + paper) / 2)


def ink_mask(image: np.ndarray, threshold: float = INK_LUMINANCE) -> np.ndarray:
    """(H, W, 3|4) or (H, W) image -> (H, W) bool ink = luminance < threshold over white."""
    return luminance(image) < threshold


def _mean_distance_to(src: np.ndarray, dst: np.ndarray) -> float:
    """Mean Euclidean distance (pixels) from each True pixel of src to the nearest True pixel of dst."""
    dist = distance_transform_edt(~dst)
    return float(dist[src].mean())


def chamfer(a: np.ndarray, b: np.ndarray, threshold: float = INK_LUMINANCE) -> float:
    """a, b: images or (H, W) bool ink masks -> symmetric mean ink distance / diagonal * 1e5; images' ink is
    what is darker than `threshold` (ink_threshold of the reference, for pale drawings).

    Empty vs empty is 0 (nothing differs); exactly one empty is inf (no
    correspondence exists, so no finite distance is meaningful).
    """
    ma = a if (a.dtype == bool and a.ndim == 2) else ink_mask(a, threshold)
    mb = b if (b.dtype == bool and b.ndim == 2) else ink_mask(b, threshold)
    if ma.shape != mb.shape:
        raise ValueError(f"chamfer needs equal shapes, got {ma.shape} and {mb.shape}")
    na, nb = bool(ma.any()), bool(mb.any())
    if not na and not nb:
        return 0.0
    if not na or not nb:
        return float("inf")
    d = 0.5 * (_mean_distance_to(ma, mb) + _mean_distance_to(mb, ma))
    return d / float(np.hypot(*ma.shape)) * CHAMFER_SCALE
