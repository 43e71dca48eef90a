"""Foreground of an ink drawing on light paper (§4.1).

Luminance (alpha composited over white), ink = local (adaptive) threshold
confirmed by a global darkness test against the paper level, morphological
closing to seal small gaps in the outline, hole filling (so an outlined
character whose interior is paper-white becomes a filled silhouette),
largest connected component.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage


def luminance(drawing: np.ndarray) -> np.ndarray:
    """(H, W) float32 luminance in [0, 1] of a (H, W, C) float32 drawing, alpha composited over white."""
    img = drawing if drawing.ndim == 3 else drawing[..., None]
    c = img.shape[2]
    color = img[..., :3] if c >= 3 else img[..., :1]
    lum = color @ np.array([0.299, 0.587, 0.114], np.float32) if color.shape[2] == 3 else color[..., 0]
    if c in (2, 4):
        alpha = img[..., -1]
        lum = lum * alpha + (1.0 - alpha)  # straight alpha over white paper
    return np.clip(lum, 0.0, 1.0).astype(np.float32)


def ink_mask(lum: np.ndarray) -> np.ndarray:
    """(H, W) bool ink pixels of a (H, W) luminance image: adaptive threshold confirmed by global darkness."""
    h, w = lum.shape
    block = max(15, (min(h, w) // 8) | 1)  # odd, a few line widths wide
    u8 = np.round(lum * 255).astype(np.uint8)
    local = cv2.adaptiveThreshold(u8, 1, cv2.ADAPTIVE_THRESH_GAUSSIAN_C, cv2.THRESH_BINARY_INV, block, 8) > 0
    # the paper level is the bright mode: tinted paper or vignetting must not read as ink
    paper = float(np.percentile(lum, 90))
    darker = lum < paper - 0.08
    # solid ink fills, where the local threshold only finds the edges; absolute too, so shaded paper is not ink
    very_dark = lum < min(paper - 0.35, 0.3)
    return (local & darker) | very_dark


def largest_component(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool: the largest 8-connected component of a (H, W) bool mask (empty stays empty)."""
    labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
    if n <= 1:
        return mask.astype(bool)
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    return labels == int(np.argmax(sizes))


def foreground_mask(drawing: np.ndarray, close_px: int | None = None) -> np.ndarray:
    """(H, W) bool filled character silhouette of a (H, W, C) float32 ink drawing on light paper."""
    lum = luminance(drawing)
    ink = ink_mask(lum)
    if drawing.ndim == 3 and drawing.shape[2] in (2, 4):
        opaque = drawing[..., -1] > 0.5
        if (~opaque).mean() > 0.01:  # a cut-out character on a transparent canvas is foreground too
            ink |= opaque
    h, w = lum.shape
    r = close_px if close_px is not None else max(3, int(round(0.01 * max(h, w))))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    # pad so closing near the frame border does not glue the character to the edge
    pad = r + 1
    padded = np.pad(ink.astype(np.uint8), pad)
    closed = cv2.morphologyEx(padded, cv2.MORPH_CLOSE, kernel)[pad:-pad, pad:-pad] > 0
    filled = ndimage.binary_fill_holes(closed)
    return largest_component(filled)
