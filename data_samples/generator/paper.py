"""Paper (colour and tooth, fixed per seed) and the photograph of a drawing: uneven light, noise, blur, JPEG."""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

# base colour (RGB 0-255), fine tooth and coarse mottling amplitudes (grey levels)
PAPERS: dict[str, tuple[tuple[float, float, float], float, float]] = {
    "white": ((255.0, 255.0, 255.0), 0.0, 0.0),  # digital drawing: no texture
    "offwhite": ((243.0, 238.0, 225.0), 2.2, 1.5),  # cold-press watercolour paper
    "sketch": ((226.0, 226.0, 221.0), 2.5, 1.5),  # light grey sketch paper
    "photo": ((241.0, 238.0, 231.0), 2.0, 1.5),  # printer paper under a phone camera
}


@dataclass(frozen=True)
class Paper:
    """A sheet: rgb (H, W, 3) float32 reflectance in [0, 1]; grain (H, W) float32 zero-mean unit-std tooth."""

    rgb: np.ndarray
    grain: np.ndarray


def _unit_noise(rng: np.random.Generator, size: tuple[int, int], sigma: float) -> np.ndarray:
    """(H, W) float32 Gaussian noise low-passed with `sigma` px, rescaled to zero mean and unit std."""
    n = cv2.GaussianBlur(rng.standard_normal(size).astype(np.float32), (0, 0), sigma)
    return (n - n.mean()) / max(float(n.std()), 1e-6)


def make_paper(kind: str, size: tuple[int, int], seed: int) -> Paper:
    """The paper of one shot or sample: same seed, same sheet in every frame."""
    base, fine_amp, coarse_amp = PAPERS[kind]
    if fine_amp == 0 and coarse_amp == 0:
        return Paper(np.full((*size, 3), np.float32(base[0] / 255.0)), np.zeros(size, np.float32))
    rng = np.random.default_rng([seed, 9001])
    grain = _unit_noise(rng, size, 0.7) * 0.6 + _unit_noise(rng, size, 2.0) * 0.4
    grain = (grain - grain.mean()) / max(float(grain.std()), 1e-6)
    mottle = _unit_noise(rng, size, 14.0)
    lum = fine_amp * grain + coarse_amp * mottle  # grey levels
    rgb = (np.asarray(base, np.float32)[None, None] + lum[..., None]) / 255.0
    return Paper(np.clip(rgb, 0, 1).astype(np.float32), grain.astype(np.float32))


@dataclass(frozen=True)
class Photo:
    """How a drawing was photographed; every field fixed per seed so all frames of a shot share it."""

    light: np.ndarray  # (H, W, 3) float32 multiplier: gradient, vignette and colour cast
    noise: np.ndarray  # (H, W, 3) float32 sensor noise, reflectance units
    blur: float  # px, Gaussian sigma of the lens
    quality: int  # JPEG quality


def make_photo(size: tuple[int, int], seed: int, quality: int | None = None) -> Photo:
    """Uneven light (a gradient plus vignette losing 17-29 grey levels across the sheet), a colour cast, noise."""
    rng = np.random.default_rng([seed, 9002])
    h, w = size
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    xx, yy = 2 * xx / (w - 1) - 1, 2 * yy / (h - 1) - 1
    ang = rng.uniform(0, 2 * np.pi)
    g = np.cos(ang) * xx + np.sin(ang) * yy
    g = (g - g.min()) / (g.max() - g.min())
    light = 1.0 - rng.uniform(0.05, 0.08) * g - rng.uniform(0.02, 0.04) * (xx ** 2 + yy ** 2) / 2
    cast = np.array([1.0, rng.uniform(0.975, 0.99), rng.uniform(0.93, 0.965)], np.float32)  # warm room light
    if rng.random() < 0.4:
        cast = cast[::-1].copy()  # or cool daylight
    noise = rng.normal(0, 1.3 / 255, (h, w, 3)).astype(np.float32)
    q = int(rng.integers(60, 76)) if quality is None else quality
    return Photo((light[..., None] * cast).astype(np.float32), noise, float(rng.uniform(0.5, 0.8)), q)


def photograph(rgb: np.ndarray, photo: Photo) -> tuple[np.ndarray, bytes]:
    """(H, W, 3) float32 drawing -> the photographed (H, W, 3) uint8 RGB as decoded, and its JPEG bytes."""
    img = cv2.GaussianBlur(rgb * photo.light, (0, 0), photo.blur) + photo.noise
    u8 = np.round(np.clip(img, 0, 1) * 255).astype(np.uint8)
    ok, buf = cv2.imencode(".jpg", np.ascontiguousarray(u8[..., ::-1]), [cv2.IMWRITE_JPEG_QUALITY, photo.quality])
    if not ok:
        raise OSError("cannot encode JPEG")
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1].copy(), buf.tobytes()
