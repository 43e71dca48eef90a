"""One finished drawing of a posed character: painted in a style, photographed if the style says so, as 8 bits."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import Character
from .paint import paint
from .paper import Paper, Photo, make_paper, make_photo, photograph
from .styles import STYLES, Palette, Style


@dataclass(frozen=True)
class Look:
    """Everything fixed per shot or sample about how it is drawn: style, palette, the sheet, the camera."""

    style: Style
    palette: Palette
    paper: Paper
    photo: Photo | None


def make_look(style: str | Style, palette: Palette, size: tuple[int, int], seed: int) -> Look:
    """The look of a shot or sample of `size` (H, W) in a style (a STYLES name or a variant);
    the same seed gives the same paper and camera."""
    st = STYLES[style] if isinstance(style, str) else style
    return Look(st, palette, make_paper(st.paper, size, seed), make_photo(size, seed) if st.photo else None)


@dataclass
class Drawing:
    """rgb (H, W, 3) uint8 as a reader decodes it; coverage per bone and union (H, W) float32 in [0, 1];
    jpeg: the file's bytes when the style is photographed (else None: write a PNG)."""

    rgb: np.ndarray
    coverage: list[np.ndarray]
    union: np.ndarray
    jpeg: bytes | None = None


def draw(char: Character, pose: np.ndarray, size: tuple[int, int], look: Look) -> Drawing:
    """Paint `char` in `pose` (J, 3) at `size` (H, W) with `look`."""
    painted = paint(char, pose, size, look.style, look.palette, look.paper)
    if look.photo is not None:
        rgb, jpeg = photograph(painted.rgb, look.photo)
        return Drawing(rgb, painted.coverage, painted.union, jpeg)
    rgb = np.round(np.clip(painted.rgb, 0, 1) * 255).astype(np.uint8)
    return Drawing(rgb, painted.coverage, painted.union)
