"""Soft edges of a drawn character: fractional coverage and the colour unmixed from the paper (§4.1, §5.1).

Every pixel of a drawing on paper is modelled as the compositing equation
    drawing = coverage * colour + (1 - coverage) * paper,
in the drawing's own encoding, the one a renderer blends in. Inside the character coverage is 1 and
colour is the drawing itself. On the outer fringe (the anti-aliased side of an outline, the soft edge of
a wash) coverage is the projection of (drawing - paper) onto (peak - paper), where the peak is the
nearest pixel of full ink, the strongest across the stroke: the two-colour matting of line art. Colour
is then solved from the equation, so coverage * colour + (1 - coverage) * paper is the drawing exactly
wherever coverage is fractional. The fringe is reached from the page without crossing the stroke's core
(its nearly strongest pixels), so the inner side of an outline and a paper-coloured inside (a white
shirt) stay opaque.
"""
from __future__ import annotations

import cv2
import numpy as np

CORE_RADIUS = 4  # pixels: core and peak are judged against the strongest ink within this reach
CORE_SHARE = 0.85  # a pixel is core (blocks the fringe) when its ΔE is this share of the strongest around it
PEAK_SHARE = 0.97  # ... and a peak, the full ink colour a fringe pixel is unmixed towards, at this share
FRINGE_PX = 6  # 4-connected steps: how far the soft edge reaches from the page before it meets the core
MIN_CONTRAST = 1e-4  # squared sRGB distance below which core and paper cannot be told apart


def nearest(seeds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) int row and column of the nearest True pixel of a non-empty (H, W) bool mask, for every pixel."""
    _, labels = cv2.distanceTransformWithLabels(
        (~seeds).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_5, labelType=cv2.DIST_LABEL_PIXEL
    )
    rows, cols = np.nonzero(seeds)
    by_label_r = np.zeros(labels.max() + 1, np.int64)
    by_label_c = np.zeros(labels.max() + 1, np.int64)
    by_label_r[labels[rows, cols]] = rows
    by_label_c[labels[rows, cols]] = cols
    return by_label_r[labels], by_label_c[labels]


def unmix(
    rgb: np.ndarray, paper: np.ndarray, solid: np.ndarray, domain: np.ndarray, delta: np.ndarray,
    ink_delta: float, paper_delta: float, fringe_px: int = FRINGE_PX,
) -> tuple[np.ndarray, np.ndarray]:
    """Coverage (H, W) float32 in [0, 1] and colour (H, W, 3) float32 of a character on paper.

    rgb, paper: (H, W, 3) float32 drawing and paper colour, same encoding; solid: (H, W) bool character
    (holes excluded); domain: (H, W) bool superset of solid where coverage may be non-zero; delta: (H, W)
    float32 ΔE*ab of the drawing from the paper; ink_delta: ΔE above which a pixel is surely ink;
    paper_delta: ΔE below which a fringe pixel is paper (coverage 0). Coverage is 0 outside domain and 1
    inside solid farther than fringe_px (through non-core pixels) from outside it.
    """
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * CORE_RADIUS + 1,) * 2)
    strongest = cv2.dilate(delta, disc)
    inked = solid & (delta > ink_delta)
    core = inked & (delta >= CORE_SHARE * strongest)
    peak = inked & (delta >= PEAK_SHARE * strongest)

    # the page side of the edge: grown from outside the character, never through a core pixel
    reach = ~solid
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))  # 4-connected: a diagonal core line blocks it
    passable = (~core).astype(np.uint8)
    grown = reach.astype(np.uint8)
    for _ in range(fringe_px):
        grown = cv2.dilate(grown, cross) & passable
    # one pixel into the core: the last partly covered pixel of a crisp anti-aliased edge is already core
    grown = grown | (cv2.dilate(grown, cross) & core.astype(np.uint8))
    fringe = (grown > 0) & domain

    if peak.any():
        ink = rgb[nearest(peak)]
    else:  # nothing stands out of the page: the character is paper-coloured, its edge cannot be softened
        ink = rgb
    toward = ink - paper
    contrast = (toward**2).sum(axis=-1)
    projected = ((rgb - paper) * toward).sum(axis=-1) / np.maximum(contrast, MIN_CONTRAST)
    alpha = np.clip(projected, 0.0, 1.0)
    alpha = np.where(contrast > MIN_CONTRAST, alpha, solid.astype(np.float32))
    alpha = np.where(delta > paper_delta, alpha, 0.0)

    coverage = np.where(fringe, alpha, solid.astype(np.float32)).astype(np.float32)
    safe = np.maximum(coverage, 1e-6)[..., None]
    colour = np.where(coverage[..., None] > 0, np.clip(paper + (rgb - paper) / safe, 0.0, 1.0), ink)
    return coverage, colour.astype(np.float32)
