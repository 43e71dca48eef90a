"""Supersampled anti-aliased rasterization of outlines and texture strokes (OpenCV fixed point)."""
from __future__ import annotations

import cv2
import numpy as np

SS = 4  # supersampling factor of the rasterizer
SHIFT = 4  # OpenCV fixed-point bits: sub-pixel accurate drawing


def to_fixed(pts: np.ndarray, origin: np.ndarray | None = None, ss: int = SS) -> np.ndarray:
    """(n, 2) output-pixel points -> int32 fixed-point coordinates of a supersampled canvas whose (0, 0)
    output pixel is `origin` (default the image's)."""
    # pixel centres: output pixel (x, y) covers supersampled [x*ss, (x+1)*ss), centre at x*ss + (ss-1)/2
    q = pts if origin is None else pts - origin
    return np.round((q * ss + (ss - 1) / 2) * (1 << SHIFT)).astype(np.int32)


def fill(shape: tuple[int, int], pts: np.ndarray, origin: np.ndarray | None = None, ss: int = SS) -> np.ndarray:
    """(h, w) float32 anti-aliased coverage of one polygon (n, 2) in output px, on a canvas of `shape`."""
    img = np.zeros(shape, np.uint8)
    cv2.fillPoly(img, [to_fixed(pts, origin, ss)], 255, cv2.LINE_AA, SHIFT)
    return img.astype(np.float32) / 255.0


def bone_frame(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bone vector d (2,) px and unit left normal n (2,): uv (u, v) maps to p0 + u d + v radius n."""
    d = p1 - p0
    return d, np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)


def strokes_image(shape: tuple[int, int], strokes: list, p0: np.ndarray, p1: np.ndarray, radius: float,
                  origin: np.ndarray | None = None, ss: int = SS) -> np.ndarray:
    """(h, w) float32 ink of the line, dot and ring strokes mapped from the bone frame to the canvas."""
    img = np.zeros(shape, np.uint8)
    d, n = bone_frame(p0, p1)
    for kind, geo, width in strokes:
        if kind == "line":
            uv = np.asarray(geo)
            pts = p0 + uv[:, :1] * d + uv[:, 1:] * radius * n
            cv2.polylines(img, [to_fixed(pts, origin, ss)], False, 255, max(1, round(width * ss)), cv2.LINE_AA, SHIFT)
        elif kind == "dot":
            c = p0 + geo[0] * d + geo[1] * radius * n
            cv2.circle(img, tuple(int(v) for v in to_fixed(c[None], origin, ss)[0]), int(round(width * ss * (1 << SHIFT))),
                       255, -1, cv2.LINE_AA, SHIFT)
        elif kind == "ring":
            c = p0 + geo[0] * d + geo[1] * radius * n
            r, w = width
            cv2.circle(img, tuple(int(v) for v in to_fixed(c[None], origin, ss)[0]), int(round(r * ss * (1 << SHIFT))),
                       255, max(1, round(w * ss)), cv2.LINE_AA, SHIFT)
    return img.astype(np.float32) / 255.0


def patch_images(shape: tuple[int, int], strokes: list, p0: np.ndarray, p1: np.ndarray, radius: float,
                 origin: np.ndarray | None = None, ss: int = SS) -> list[tuple[str, np.ndarray]]:
    """Per "patch" stroke: its material and (h, w) float32 coverage on the canvas."""
    d, n = bone_frame(p0, p1)
    out = []
    for kind, geo, material in strokes:
        if kind == "patch":
            uv = np.asarray(geo)
            out.append((material, fill(shape, p0 + uv[:, :1] * d + uv[:, 1:] * radius * n, origin, ss)))
    return out
