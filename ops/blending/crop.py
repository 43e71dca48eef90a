"""Where RIFE needs to look: the box around a pair's ink plus a margin, on the network's pixel grid (§5.2).

The deformed frames are transparent outside the character, and a transparent
pixel is white paper to the network. Running the network on the box around
the ink of both images instead of the whole frame gives the same midpoint
there (up to the network's border effects, which the margin keeps away from
the ink) at a fraction of the cost. Corners lie on multiples of `GRID`
pixels, so the crop samples the network's coarse levels (1/16 of the frame
at the first block) at the same phases as the full frame does.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

MARGIN = 32  # pixels of paper kept around the ink: more than the flows between two matrix cells move it
GRID = 32  # box corners on multiples of this (RIFE pads to 32 and downsamples by up to 16)
INK = 1e-3  # coverage above this counts as ink when deciding whether a box cut through the drawing


@dataclass(frozen=True)
class Box:
    """Half-open pixel box [y0, y1) x [x0, x1) of an (H, W) frame."""

    y0: int
    y1: int
    x0: int
    x1: int

    @property
    def slices(self) -> tuple[slice, slice]:
        return slice(self.y0, self.y1), slice(self.x0, self.x1)

    @property
    def area(self) -> int:
        return (self.y1 - self.y0) * (self.x1 - self.x0)


def _snap(lo: int, hi: int, margin: int, size: int, grid: int) -> tuple[int, int]:
    """[lo, hi) grown by margin on both sides, lo down and hi up to the grid, clipped to [0, size)."""
    return max(0, (lo - margin) // grid * grid), min(size, -(-(hi + margin) // grid) * grid)


def coverage_box(alpha: Any, margin: int = MARGIN, grid: int = GRID) -> Box | None:
    """alpha: (..., H, W) coverage of any number of images (an array, or a tensor on any device) -> the box around
    every pixel covered in any of them, grown by `margin` pixels and snapped outwards to `grid` (clipped to the
    frame); None when nothing is covered."""
    covered = (alpha.reshape(-1, *alpha.shape[-2:]) > 0).any(0)
    covered = np.asarray(covered.cpu() if hasattr(covered, "cpu") else covered)  # (H, W) bool on the host
    rows = np.nonzero(covered.any(1))[0]
    if len(rows) == 0:
        return None
    cols = np.nonzero(covered.any(0))[0]
    h, w = covered.shape
    y0, y1 = _snap(int(rows[0]), int(rows[-1]) + 1, margin, h, grid)
    x0, x1 = _snap(int(cols[0]), int(cols[-1]) + 1, margin, w, grid)
    return Box(y0, y1, x0, x1)


def grow(box: Box, shape: tuple[int, int], margin: int = MARGIN, grid: int = GRID) -> Box:
    """The box grown by `margin` on every side and snapped to `grid`, clipped to the (H, W) frame."""
    y0, y1 = _snap(box.y0, box.y1, margin, shape[0], grid)
    x0, x1 = _snap(box.x0, box.x1, margin, shape[1], grid)
    return Box(y0, y1, x0, x1)


def cuts_ink(alpha: Any, box: Box, shape: tuple[int, int], ink: float = INK) -> bool:
    """alpha: (..., h, w) coverage (an array or a tensor) computed inside `box` of an (H, W) frame -> True when ink reaches an edge of the
    box that is not an edge of the frame (the full frame might have ink beyond it: the box is too small)."""
    h, w = shape
    edges = []
    if box.y0 > 0:
        edges.append(alpha[..., 0, :])
    if box.y1 < h:
        edges.append(alpha[..., -1, :])
    if box.x0 > 0:
        edges.append(alpha[..., :, 0])
    if box.x1 < w:
        edges.append(alpha[..., :, -1])
    return any(bool((e > ink).any()) for e in edges)
