"""Soft edges of a drawn character: fractional coverage and the colour unmixed from the paper (§4.1, §5.1).

Every pixel of a drawing on paper is modelled as the compositing equation
    drawing = coverage * colour + (1 - coverage) * paper,
in the drawing's own encoding, the one a renderer blends in. Inside the character coverage is 1 and
colour is the drawing itself. On the outer fringe (the anti-aliased side of an outline, the soft edge of
a wash) coverage is the projection of (drawing - paper) onto (full - paper), where "full" is the full
ink the pixel is a mix of: the strongest ink met walking inward from it, across the stroke or up the
wash's ramp (walking inward, not taking the nearest strong pixel, keeps a white boot's edge from being
unmixed towards the black trousers next to it): the two-colour matting of line art. Colour is then
solved from the equation, so coverage * colour + (1 - coverage) * paper is the drawing exactly wherever
coverage is fractional. The fringe is the page-facing half of the ink: pixels nearer the page than the
character's paper-coloured inside (the inside of an outline, a white shirt), which with the inner half of
the outline stays opaque. The inside is the paper the ink encloses, found twice: between the drawn
pixels themselves (a thin strip inside a narrow outlined limb), and between the ink with its gaps closed
(a pencil outline broken up by the paper's tooth, whose inside leaks out between grains).
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

FRINGE_PX = 6  # pixels: how far in from the page the soft edge of a wash or a thick stroke may reach
WALK_PX = 6  # pixels: how far inward the full ink of a fringe pixel is looked for
MIN_CONTRAST = 1e-4  # squared sRGB distance below which ink and paper cannot be told apart
FAR = 1e6  # distance, pixels, to a region the image does not have
FULL_SHARE = 0.97  # a pixel within this share of its full ink's ΔE is full ink itself (the rest is noise)
GAMUT_TOLERANCE = 2.0 / 255  # per channel: colour clipped by less than this is not worth raising coverage
MIN_INSIDE_PX = 16  # paper inside the character smaller than this is a speck in a stroke, not its inside


def enclosed(paper_like: np.ndarray, page: np.ndarray, min_px: int = MIN_INSIDE_PX) -> np.ndarray:
    """(H, W) bool components of a (H, W) bool mask that touch no pixel of the (H, W) bool page, each >= min_px."""
    labels, n = ndimage.label(paper_like)
    if n == 0:
        return paper_like.copy()
    keep = np.bincount(labels.ravel(), minlength=n + 1) >= min_px
    keep[np.unique(labels[cv2.dilate(page.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0])] = False
    keep[0] = False
    return keep[labels]


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


def _distance_to(region: np.ndarray) -> np.ndarray:
    """(H, W) float32 Euclidean distance, pixels, of every pixel to the nearest True pixel of region (FAR if none)."""
    if not region.any():
        return np.full(region.shape, FAR, np.float32)
    return cv2.distanceTransform((~region).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def walk(delta: np.ndarray, depth: np.ndarray, rows: np.ndarray, cols: np.ndarray, steps: int,
         stop: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The strongest ink met walking from each of n pixels (rows, cols) `steps` one-pixel steps inward
    (steps < 0: outward), the pixel itself included: (n,) row, (n,) column and (n,) ΔE of it.

    delta: (H, W) ΔE*ab from the paper; depth: (H, W) float32 signed distance into the character, pixels;
    stop: (H, W) bool where a walk ends (the page, walking outward: ink beyond it is another body's).
    """
    gy, gx = np.gradient(depth)
    norm = np.maximum(np.hypot(gx[rows, cols], gy[rows, cols]), 1e-6)
    sign = 1 if steps > 0 else -1
    ux, uy = sign * gx[rows, cols] / norm, sign * gy[rows, cols] / norm
    h, w = delta.shape
    best_r, best_c, best = rows.copy(), cols.copy(), delta[rows, cols].copy()
    going = np.ones(len(rows), bool)
    for t in range(1, abs(steps) + 1):
        r = np.clip(np.round(rows + t * uy).astype(np.int64), 0, h - 1)
        c = np.clip(np.round(cols + t * ux).astype(np.int64), 0, w - 1)
        if stop is not None:
            going &= ~stop[r, c]
        d = delta[r, c]
        better = going & (d > best)
        best_r[better], best_c[better], best[better] = r[better], c[better], d[better]
    return best_r, best_c, best


def gamut_alpha(mixed: np.ndarray, paper: np.ndarray, tolerance: float = GAMUT_TOLERANCE) -> np.ndarray:
    """(n,) least coverage whose unmixed colour paper + mixed / coverage stays in [0, 1] (for (n, 3) arrays),
    to within `tolerance` per channel: below that, clipping the colour costs less than inventing coverage."""
    up = np.maximum(mixed - tolerance, 0.0) / np.maximum(1.0 - paper, 1e-6)
    down = np.maximum(-mixed - tolerance, 0.0) / np.maximum(paper, 1e-6)
    return np.maximum(up, down).max(axis=-1)


def unmix(
    rgb: np.ndarray, paper: np.ndarray, solid: np.ndarray, domain: np.ndarray, ink: np.ndarray,
    sealed: np.ndarray, delta: np.ndarray, ink_delta: float, paper_delta: float, fringe_px: int = FRINGE_PX,
) -> tuple[np.ndarray, np.ndarray]:
    """Coverage (H, W) float32 in [0, 1] and colour (H, W, 3) float32 of a character on paper.

    rgb, paper: (H, W, 3) float32 drawing and paper colour, same encoding; solid: (H, W) bool character
    (holes excluded); domain: (H, W) bool superset of solid where coverage may be non-zero; ink, sealed:
    (H, W) bool drawn pixels, as found and with small gaps closed; delta: (H, W) float32 ΔE*ab of the
    drawing from the paper; ink_delta: ΔE the full ink of a fringe pixel must exceed, else the pixel is
    paper; paper_delta: ΔE below which a fringe pixel is paper. Coverage is 0 outside domain, fractional
    on the fringe (domain outside solid, and the page-facing side of solid up to fringe_px deep), 1
    elsewhere in solid; colour is the drawing wherever coverage is 1.
    """
    page = ~solid
    inside = enclosed(solid & ~ink, page) | enclosed(solid & ~sealed, page)
    to_page = _distance_to(page)
    fringe = (domain & page) | (solid & ~inside & (to_page <= fringe_px) & (to_page < _distance_to(inside)))

    coverage = solid.astype(np.float32)
    colour = rgb.astype(np.float32).copy()
    depth = to_page - _distance_to(solid)
    rows, cols = np.nonzero(fringe)
    # a pixel with stronger ink between it and the page lies behind that stroke: it is covered. The walk
    # ends at the page: from paper glued between two bodies it would cross a sliver of paper into the
    # other body's edge and leave an opaque paper speck that travels with the limb
    _, _, outward = walk(delta, depth, rows, cols, -fringe_px, stop=page)
    front = solid[rows, cols] & (outward > delta[rows, cols] + ink_delta)
    rows, cols = rows[~front], cols[~front]
    if len(rows):
        fr, fc, full_delta = walk(delta, depth, rows, cols, WALK_PX)
        full = rgb[fr, fc]
        toward = full - paper[rows, cols]
        contrast = (toward**2).sum(axis=-1)
        mixed = rgb[rows, cols] - paper[rows, cols]
        alpha = np.clip((mixed * toward).sum(axis=-1) / np.maximum(contrast, MIN_CONTRAST), 0.0, 1.0)
        alpha = np.where(delta[rows, cols] >= FULL_SHARE * full_delta, 1.0, alpha)
        # no ink to be a mix of, or a pixel the page's own noise explains: paper
        paperlike = (full_delta <= ink_delta) | (contrast <= MIN_CONTRAST) | (delta[rows, cols] <= paper_delta)
        # the least coverage that explains the pixel with a colour in gamut: the equation then holds exactly
        alpha = np.where(paperlike, 0.0, np.clip(np.maximum(alpha, gamut_alpha(mixed, paper[rows, cols])), 0, 1))
        coverage[rows, cols] = alpha
        solved = paper[rows, cols] + mixed / np.maximum(alpha, 1e-6)[:, None]
        colour[rows, cols] = np.where(alpha[:, None] > 0, np.clip(solved, 0.0, 1.0), full)
    return coverage, colour
