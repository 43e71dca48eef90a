"""The paper under a drawing: a smooth colour surface estimated from the image itself (§4.1, foreground).

Paper is whatever the border and the bright majority of the image agree on: off-white, tinted or
unevenly lit. Its colour is modelled as a low-order polynomial surface in linear RGB (illumination
multiplies reflectance, so uneven lighting of one paper colour is smooth there), fitted by iteratively
reweighted least squares (Tukey's biweight on the CIELAB colour difference ΔE*ab) to an area-averaged
thumbnail, which also averages away paper grain and JPEG noise. Ink, washes and fills are the outliers.
What the cubic cannot follow (the shadow in a photo's corner, a fold) is added as the paper cells'
residual smoothed by normalised convolution; where no paper is near (inside a large fill) that
correction fades out and the polynomial alone bridges the gap.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

THUMB_SIDE = 96  # thumbnail long side, pixels: enough samples for a cubic, cheap, grain averaged out
BORDER_CELLS = 2  # thumbnail cells along each edge that seed the paper colour
SEED_DELTA_E = 20.0  # ΔE*ab from the border colour a thumbnail cell may have to enter the first fit
TUKEY_C = 4.685  # Tukey biweight cut-off in robust standard deviations (95 % efficiency)
MIN_SCALE = 0.5  # ΔE*ab floor of the robust scale, so a noiseless synthetic page does not reject every cell
IRLS_ITERATIONS = 8
RESIDUAL_SIGMA = 0.05  # share of the thumbnail's long side: the scale of shading the residual follows
RESIDUAL_SUPPORT = 0.3  # normalised-convolution weight at which the residual is trusted in full


@dataclass
class Paper:
    """Paper colour at every pixel and the noise of the page around it."""

    rgb: np.ndarray  # (H, W, 3) float32 paper colour, the drawing's (sRGB) encoding, [0, 1]
    lab: np.ndarray  # (H, W, 3) float32 the same colour in CIELAB (L* 0..100)
    noise: float  # median ΔE*ab of paper pixels from the model: grain, JPEG and sensor noise, ΔE units


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in [0, 1] -> linear light, same shape, float32 (IEC 61966-2-1)."""
    c = np.clip(c, 0.0, 1.0).astype(np.float32)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """Linear light in [0, 1] -> sRGB-encoded values, same shape, float32."""
    c = np.clip(c, 0.0, 1.0).astype(np.float32)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055).astype(np.float32)


def to_lab(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) float sRGB in [0, 1] -> (..., 3) float32 CIELAB (D65; L* 0..100, a*, b* about -128..127)."""
    flat = np.ascontiguousarray(np.clip(rgb, 0.0, 1.0), dtype=np.float32).reshape(-1, 1, 3)
    return cv2.cvtColor(flat, cv2.COLOR_RGB2Lab).reshape(rgb.shape)


def delta_e(lab_a: np.ndarray, lab_b: np.ndarray) -> np.ndarray:
    """(...,) float32 CIE76 colour difference ΔE*ab between (..., 3) CIELAB arrays."""
    return np.sqrt(((lab_a - lab_b) ** 2).sum(axis=-1)).astype(np.float32)


def polynomial_terms(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    """(n, n_terms) float64 monomials x^i y^j, i + j <= degree, of (n,) coordinates normalised to [-1, 1]."""
    cols = [x**i * y ** (d - i) for d in range(degree + 1) for i in range(d + 1)]
    return np.stack(cols, axis=1).astype(np.float64)


def _grid(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """(h * w,) x and (h * w,) y of pixel centres, normalised to [-1, 1] over the image."""
    ys, xs = np.mgrid[0:h, 0:w]
    return ((xs + 0.5) / w * 2 - 1).ravel(), ((ys + 0.5) / h * 2 - 1).ravel()


def _tukey(r: np.ndarray, c: float) -> np.ndarray:
    """(n,) Tukey biweight weights of (n,) non-negative residuals at cut-off c."""
    u = np.clip(r / c, 0.0, 1.0)
    return (1.0 - u**2) ** 2


def _smooth_residual(residual: np.ndarray, weights: np.ndarray, sigma: float) -> np.ndarray:
    """(h, w, 3) residual smoothed over the cells' (h, w) weights; faded to 0 where the weights are sparse."""
    w = cv2.GaussianBlur(weights.astype(np.float32), (0, 0), sigma)
    num = cv2.GaussianBlur((residual * weights[..., None]).astype(np.float32), (0, 0), sigma)
    trust = np.clip(w / RESIDUAL_SUPPORT, 0.0, 1.0)[..., None]
    return (num / np.maximum(w, 1e-6)[..., None] * trust).astype(np.float64)


def estimate_paper(rgb: np.ndarray, lab: np.ndarray | None = None, degree: int = 3) -> Paper:
    """Paper model of a (H, W, 3) float32 sRGB drawing (lab: its (H, W, 3) CIELAB, if known): degree-d surface."""
    h, w = rgb.shape[:2]
    scale = min(1.0, THUMB_SIDE / max(h, w))
    tw, th = max(2, round(w * scale)), max(2, round(h * scale))
    # averaged before linearising: on a page (nearly one colour per cell) the order makes no difference
    small = cv2.resize(np.ascontiguousarray(rgb, np.float32), (tw, th), interpolation=cv2.INTER_AREA)
    thumb = srgb_to_linear(small).reshape(-1, 3).astype(np.float64)
    thumb_lab = to_lab(linear_to_srgb(thumb))
    terms = polynomial_terms(*_grid(th, tw), degree)

    # seed: the median colour of the border cells; the page shows there unless the drawing is cropped tight
    border = np.zeros((th, tw), bool)
    b = min(BORDER_CELLS, th // 2, tw // 2)
    border[:b], border[-b:], border[:, :b], border[:, -b:] = True, True, True, True
    seed = np.median(thumb_lab.reshape(th, tw, 3)[border], axis=0)
    # the bright mode guards against a border that is mostly drawing: paper is the lighter of the two
    bright = thumb_lab[:, 0] >= np.percentile(thumb_lab[:, 0], 50)
    mode = np.median(thumb_lab[bright], axis=0)
    if mode[0] > seed[0] + SEED_DELTA_E:
        seed = mode
    weights = (delta_e(thumb_lab, seed) < SEED_DELTA_E).astype(np.float64)
    if weights.sum() < terms.shape[1] * 4:  # too few cells near the seed to fit a surface: start from all of them
        weights[:] = 1.0

    coef = np.zeros((terms.shape[1], 3))
    correction = np.zeros((th, tw, 3))
    sigma = RESIDUAL_SIGMA * max(th, tw)
    for it in range(IRLS_ITERATIONS):
        weighted = terms * weights[:, None]
        target = thumb - correction.reshape(-1, 3)
        # normal equations: a 10 x 10 (degree 3) system, well conditioned on [-1, 1] coordinates
        coef = np.linalg.solve(weighted.T @ terms + 1e-9 * np.eye(terms.shape[1]), weighted.T @ target)
        smooth = terms @ coef
        if it >= IRLS_ITERATIONS // 2:  # once the polynomial has settled, let the residual follow local shading
            correction = _smooth_residual((thumb - smooth).reshape(th, tw, 3), weights.reshape(th, tw), sigma)
        model_lab = to_lab(linear_to_srgb(smooth + correction.reshape(-1, 3)))
        r = delta_e(thumb_lab, model_lab).astype(np.float64)
        scale_r = max(1.4826 * float(np.median(r[weights > 0])), MIN_SCALE)
        weights = _tukey(r, TUKEY_C * scale_r)

    # the model is smooth on the thumbnail's scale: evaluate it there, interpolate to every pixel
    model = linear_to_srgb((terms @ coef).reshape(th, tw, 3) + correction)
    paper_rgb = cv2.resize(model, (w, h), interpolation=cv2.INTER_LINEAR)
    paper_lab = cv2.resize(to_lab(model), (w, h), interpolation=cv2.INTER_LINEAR)
    d = delta_e(to_lab(rgb) if lab is None else lab, paper_lab)
    # noise from the pixels the fit called paper, upsampled from the thumbnail
    inlier = cv2.resize((weights > 0).reshape(th, tw).astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST) > 0
    noise = float(np.median(d[inlier])) if inlier.any() else float(np.median(d))
    return Paper(rgb=paper_rgb, lab=paper_lab, noise=noise)
