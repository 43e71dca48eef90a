"""The original ink renderer of the first six sample shots, kept bit for bit: grey ink on white, composited at 4x."""
from __future__ import annotations

import cv2
import numpy as np

from .geometry import part_outline
from .model import Character
from .order import draw_order
from .raster import SS, fill, strokes_image

INK_WIDTH = 2.4  # mean outline width, output pixels


def render_with_union(char: Character, pose: np.ndarray, size: tuple[int, int]
                      ) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """(H, W, 3) uint8 RGB on white paper, per bone (H, W) float32 coverage, (H, W) float32 union coverage."""
    h, w = size
    big = (h * SS, w * SS)
    canvas = np.ones(big, np.float32)
    union = np.zeros(big, np.float32)
    coverage: list[np.ndarray] = [np.zeros(size, np.float32)] * len(char.bones)
    for i in draw_order(char, pose):
        p, c = char.bones[i]
        part = char.parts[c]
        pts, nrm, param = part_outline(part, pose[p, :2], pose[c, :2])
        ph = char.weight_phase[c]
        width = INK_WIDTH * (1 + 0.16 * np.sin(2 * param + ph[0]) + 0.08 * np.sin(5 * param + ph[1]))
        outer = fill(big, pts + nrm * (0.5 * width)[:, None])
        inner = fill(big, pts - nrm * (0.5 * width)[:, None])
        tex = strokes_image(big, char.strokes[c], pose[p, :2], pose[c, :2], part.radius)
        ink = np.maximum(np.clip(outer - inner, 0, 1), tex * inner)
        canvas = canvas * (1 - outer) + (1 - ink) * outer
        union = np.maximum(union, outer)  # supersampled union: exact coverage where two parts abut
        coverage[i] = cv2.resize(outer, (w, h), interpolation=cv2.INTER_AREA)
    grey = cv2.resize(canvas, (w, h), interpolation=cv2.INTER_AREA)
    rgb = np.repeat(np.round(np.clip(grey, 0, 1) * 255).astype(np.uint8)[..., None], 3, 2)
    return rgb, coverage, cv2.resize(union, (w, h), interpolation=cv2.INTER_AREA)


def render(char: Character, pose: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, list[np.ndarray]]:
    """Paint the character: (H, W, 3) uint8 RGB on white paper, and per bone (H, W) float32 coverage."""
    rgb, coverage, _ = render_with_union(char, pose, size)
    return rgb, coverage
