"""Image inpainting behind a small interface, so a learned inpainter can replace OpenCV's."""
from __future__ import annotations

from typing import Protocol

import cv2
import numpy as np

_METHODS = {"telea": cv2.INPAINT_TELEA, "ns": cv2.INPAINT_NS}


class Inpainter(Protocol):
    """Fills the hole pixels of an image from their surroundings."""

    def __call__(self, image: np.ndarray, hole: np.ndarray) -> np.ndarray:
        """image: (H, W, 3) float32 [0, 1], hole: (H, W) bool -> (H, W, 3) float32, unchanged outside the hole."""
        ...


class OpenCVInpainter:
    """cv2.inpaint (Telea fast marching or Navier-Stokes) on an 8-bit copy; pixels outside the hole stay exact."""

    def __init__(self, radius: int = 5, method: str = "telea"):
        if method not in _METHODS:
            raise ValueError(f"inpainter method {method!r}: use one of {sorted(_METHODS)}")
        if radius < 1:
            raise ValueError(f"inpainter radius {radius}: use a positive number of pixels")
        self.radius, self.method = int(radius), method

    def __call__(self, image: np.ndarray, hole: np.ndarray) -> np.ndarray:
        """image: (H, W, 3) float32 [0, 1], hole: (H, W) bool -> (H, W, 3) float32."""
        out = np.array(image, dtype=np.float32, copy=True)
        hole = np.asarray(hole, dtype=bool)
        if not hole.any():
            return out
        img8 = np.round(np.clip(out, 0.0, 1.0) * 255.0).astype(np.uint8)
        filled = cv2.inpaint(img8, hole.astype(np.uint8), self.radius, _METHODS[self.method])
        out[hole] = filled[hole].astype(np.float32) / 255.0
        return out
