"""The character's silhouette on a drawing found without any skeleton: the prior that placement starts from.

The project's foreground (ops.segmentation.foreground) needs a pose as its prior; here there is none yet.
Its paper model and ink rule are reused (ops.segmentation.paper, foreground.read_page): ink is what differs
from the local paper colour in CIELAB by more than the page's noise allows; pencil gaps are closed, the
insides filled, and the character is the largest ink component plus the pieces that lie beside it (a head
drawn apart from its body), never specks, a signature far away or the dark edge of a photographed table.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy import ndimage

from ops.geometry.polygon import box_size
from ops.segmentation.foreground import close_radius, closing, is_cutout, read_page
from ops.shotio.image_io import to_rgba

PIECE_SHARE = 0.04  # a component of at least this share of the largest one's area may be part of the character
PIECE_REACH = 0.08  # ... when it lies within this share of the character's size of it
BORDER_SHARE = 0.25  # a component running along more than this share of the image's edge is the table, not ink
MIN_AREA_SHARE = 0.002  # a drawing whose character covers less of the image than this has none
MAX_AREA_SHARE = 0.95  # ... or more than this: no paper to tell it from


@dataclass
class Silhouette:
    """A drawing's character: filled silhouette and the ink strokes it was made of."""

    mask: np.ndarray  # (H, W) bool character, insides filled
    ink: np.ndarray  # (H, W) bool drawn pixels (strokes and fills) inside the mask
    warnings: list[str] = field(default_factory=list)


def _border_run(labels: np.ndarray, n: int) -> np.ndarray:
    """(n + 1,) share of the image's edge pixels each label covers."""
    edge = np.concatenate([labels[0], labels[-1], labels[1:-1, 0], labels[1:-1, -1]])
    return np.bincount(edge, minlength=n + 1) / float(len(edge))


def find_silhouette(drawing: np.ndarray) -> Silhouette:
    """Silhouette of a (H, W, C) float32 [0, 1] drawing (straight alpha) with no pose to guide it.

    Raises ValueError('no character ...') when nothing or everything differs from the paper.
    """
    rgba = to_rgba(drawing)
    h, w = rgba.shape[:2]
    if is_cutout(rgba):
        ink = rgba[..., 3] > 0.5
        mask, warnings = _main_shape(ink)
    else:
        page = read_page(np.ascontiguousarray(rgba[..., :3]))
        ink = page.smooth_delta > page.ink_delta
        r = close_radius((h, w))
        mask, warnings = _main_shape(closing(ink, r))
        own = close_radius(box_size(mask))  # gaps sealed by the character's size, not its page's
        if own < r:
            mask, warnings = _main_shape(closing(ink, own))
    return Silhouette(mask=mask, ink=ink & mask, warnings=warnings)


def _main_shape(sealed: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """(H, W) bool the character in an (H, W) bool sealed ink mask (its largest filled shape, with the pieces
    near it), and warnings; ValueError when there is none."""
    h, w = sealed.shape
    filled = ndimage.binary_fill_holes(sealed)
    labels, n = ndimage.label(filled, structure=np.ones((3, 3), bool))
    if n == 0:
        raise ValueError("no character: nothing on the image differs from the paper")
    sizes = np.bincount(labels.ravel(), minlength=n + 1).astype(np.float64)
    sizes[0] = 0
    warnings = []
    table = _border_run(labels, n) > BORDER_SHARE
    table[0] = False
    if table.any():
        warnings.append("ignored a dark region along the image's edge (a table or the photo's border)")
        sizes[table] = 0
    main = int(np.argmax(sizes))
    if sizes[main] < MIN_AREA_SHARE * h * w:
        raise ValueError(f"no character: the largest drawn shape covers {sizes[main] / (h * w):.2%} of the image")
    if sizes[main] > MAX_AREA_SHARE * h * w:
        raise ValueError("no character: the whole image differs from its edges (a photo, not a drawing on paper)")
    body = labels == main
    ys, xs = np.nonzero(body)
    reach = PIECE_REACH * max(np.ptp(ys) + 1, np.ptp(xs) + 1)
    near = cv2.distanceTransform((~body).astype(np.uint8), cv2.DIST_L2, 5) <= reach
    keep = [main] + [int(i) for i in range(1, n + 1)
                     if i != main and sizes[i] >= PIECE_SHARE * sizes[main] and near[labels == i].any()]
    return np.isin(labels, keep), warnings
