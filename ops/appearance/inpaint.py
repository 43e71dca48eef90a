"""Image inpainting behind a small interface, so a learned inpainter can replace OpenCV's (§5.1).

Methods: "telea" and "ns" (cv2.inpaint: fast marching or Navier-Stokes, every hole alike), "flat" (every hole
filled from its surroundings' flat colours, strokes continued: ops.appearance.flat_fill) and "auto" (per
connected hole, flat where its surroundings are flat colour, Telea where they are textured).
"""
from __future__ import annotations

import inspect
from typing import Protocol

import cv2
import numpy as np

from ops.appearance.flat_fill import FlatInpainter

_OPENCV = {"telea": cv2.INPAINT_TELEA, "ns": cv2.INPAINT_NS}
INPAINT_METHODS = ("auto", "flat", "telea", "ns")


class Inpainter(Protocol):
    """Fills the hole pixels of an image from their surroundings.

    `coverage` (H, W) float32 in [0, 1], optional: how much of each pixel is character rather than paper (the
    flat-colour inpainter takes no colour from paper). An inpainter written for the first version of this
    protocol, without `coverage`, still works: `inpaint` calls it without.
    """

    def __call__(self, image: np.ndarray, hole: np.ndarray, coverage: np.ndarray | None = None) -> np.ndarray:
        """image: (H, W, 3) float32 [0, 1], hole: (H, W) bool -> (H, W, 3) float32, unchanged outside the hole."""
        ...


class OpenCVInpainter:
    """cv2.inpaint (Telea fast marching or Navier-Stokes) on an 8-bit copy; pixels outside the hole stay exact."""

    def __init__(self, radius: int = 5, method: str = "telea"):
        if method not in _OPENCV:
            raise ValueError(f"inpainter method {method!r}: use one of {sorted(_OPENCV)}")
        if radius < 1:
            raise ValueError(f"inpainter radius {radius}: use a positive number of pixels")
        self.radius, self.method = int(radius), method

    def __call__(self, image: np.ndarray, hole: np.ndarray, coverage: np.ndarray | None = None) -> np.ndarray:
        """image: (H, W, 3) float32 [0, 1], hole: (H, W) bool -> (H, W, 3) float32 (coverage is not used)."""
        out = np.array(image, dtype=np.float32, copy=True)
        hole = np.asarray(hole, dtype=bool)
        if not hole.any():
            return out
        img8 = np.round(np.clip(out, 0.0, 1.0) * 255.0).astype(np.uint8)
        filled = cv2.inpaint(img8, hole.astype(np.uint8), self.radius, _OPENCV[self.method])
        out[hole] = filled[hole].astype(np.float32) / 255.0
        return out


def make_inpainter(method: str = "telea", radius: int = 5) -> Inpainter:
    """The inpainter of a method name (INPAINT_METHODS) and neighbourhood radius (pixels)."""
    if method in _OPENCV:
        return OpenCVInpainter(radius=radius, method=method)
    if method in ("auto", "flat"):
        return FlatInpainter(mode=method, radius=radius)
    raise ValueError(f"inpainter method {method!r}: use one of {list(INPAINT_METHODS)}")


def _takes_coverage(inpainter: Inpainter) -> bool:
    """Whether the callable accepts a `coverage` argument (or any keyword)."""
    try:
        params = inspect.signature(inpainter).parameters.values()
    except (TypeError, ValueError):  # a builtin or C callable: call it as the first protocol did
        return False
    return any(p.name == "coverage" or p.kind is p.VAR_KEYWORD for p in params)


def inpaint(inpainter: Inpainter, image: np.ndarray, hole: np.ndarray, coverage: np.ndarray | None = None
            ) -> np.ndarray:
    """Run any inpainter: (H, W, 3) float32 image, (H, W) bool hole, (H, W) float32 coverage -> (H, W, 3) float32,
    with the coverage only for inpainters that take it."""
    if coverage is not None and _takes_coverage(inpainter):
        return np.asarray(inpainter(image, hole, coverage=coverage), dtype=np.float32)
    return np.asarray(inpainter(image, hole), dtype=np.float32)
