"""Foreground of a character drawn on paper (§4.1): what differs from the paper in colour, as the skeleton sees it.

1. The paper colour is modelled at every pixel (ops.segmentation.paper), so tinted, off-white and
   unevenly lit paper is no ink.
2. Ink is any colour far enough from the local paper in CIELAB (ΔE*ab): dark lines, but also pale skin,
   yellow and light washes, which luminance alone misses. The threshold follows the page's own noise.
3. Small gaps in outlines are closed; the enclosed insides filled, and so are insides the frame cuts
   open (a leg running off the bottom edge) where a bone runs through them, and insides a bone runs through
   the middle of whose outline is drawn in strokes with wider breaks (closed at four times the radius for them
   alone).
4. The skeleton is the prior: every component a bone touches is kept, and so is a stroke no bone touches that
   lies within a limb's reach of one (an outline drawn in separate strokes); specks and dots there are dropped.
5. Enclosed paper that is background seen through the body becomes a hole (ops.segmentation.holes).
6. The edge gets fractional coverage and the colour unmixed from the paper (ops.segmentation.coverage);
   the mask reaches MARGIN_PX past the ink, a rim whose coverage falls to 0, so that the mesh boundary,
   simplified to 2 px, still holds the whole soft edge.

A drawing with real transparency (an RGBA cut-out) is segmented by its alpha instead.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import cv2
import numpy as np
from scipy import ndimage

from ops.geometry.polygon import box_size
from ops.segmentation.bones import bone_capsules, bone_radii, bone_samples
from ops.segmentation.coverage import unmix
from ops.segmentation.holes import find_holes
from ops.segmentation.paper import Paper, delta_e, estimate_paper, to_lab
from ops.shotio.image_io import to_rgba
from ops.types import Skeleton

INK_DELTA_E = 4.0  # ΔE*ab: the least colour difference from the paper that counts as drawn (a just-visible wash)
NOISE_FACTOR = 3.5  # the threshold is at least this many times the page's median noise ΔE
PAPER_FACTOR = 1.5  # a fringe pixel within this many times the median noise of the paper is paper ...
MIN_PAPER_DELTA_E = 1.0  # ... or within this ΔE*ab of it (a noiseless page)
BLUR_SIGMA = 0.8  # pixels: averages paper grain and JPEG noise before the ink decision
CLOSE_SHARE = 0.008  # closing radius as a share of the image's long side: seals pencil gaps, keeps limbs apart
BROKEN_SCALE = 4  # an inside a bone crosses is sealed across gaps this many times the closing radius
MIDDLE_SHARE = 0.5  # ... when the bone reaches this share of the inside's greatest depth (runs through its middle)
BONE_TOUCH_PX = 2.0  # a component a bone passes within this distance of is touched by it
CROSS_PX = 0.5  # a paper piece a bone's line (this thick) runs through is the inside of a limb, not a hole; one
#                 it passes within BONE_TOUCH_PX of is unless wide (holes.find_holes: a forearm beside the face)
WALL_SCALE, WALL_MARGIN_PX = 2.0, 4.0  # ink within WALL_SCALE x body radius + margin of a bone belongs to that body part
MARGIN_PX = 2  # the mask reaches this far past the ink: the 2-px Douglas-Peucker mesh boundary keeps the soft edge
TRANSPARENT_SHARE = 0.01  # RGBA with more than this share of pixels not fully opaque is a cut-out
STROKE_AREA = 4.0  # an untouched stroke this many closing radii squared (16 px at 256 px) or more is no speck
NEAR_SHARE = 0.9  # ... and is kept when this share of it lies within a body's reach of a bone
ELONGATION = 2.0  # ... and a stroke, at least this many times longer than wide
LIMB_SHARE = 0.35  # ... the reach of a bone for that: at least this share of its length
MIN_BONE_SAMPLES = 3  # bone samples (2 px apart) in a region the frame cuts open that make it an inside


@dataclass
class Foreground:
    """A keyframe's character: its mask with holes, soft coverage and colour, and the paper under it."""

    mask: np.ndarray  # (H, W) bool, True = character: every pixel with coverage > 0 and a rim of up to MARGIN_PX
    #                   where it falls to 0; holes are False
    coverage: np.ndarray  # (H, W) float32 in [0, 1]: 1 inside, fractional on soft edges, 0 on paper and in holes
    colour: np.ndarray  # (H, W, 3) float32 character colour: drawing = coverage * colour + (1 - coverage) * paper
    paper: np.ndarray  # (H, W, 3) float32 paper colour under every pixel (white for a cut-out)
    holes: np.ndarray  # (H, W) bool enclosed paper that is background seen through the body
    n_holes: int  # connected holes
    warnings: list[str] = field(default_factory=list)


def close_radius(shape: tuple[int, int]) -> int:
    """Closing radius, pixels, for an image of (H, W): about 0.8 % of its long side, at least 2."""
    return max(2, int(round(CLOSE_SHARE * max(shape))))


def closing(mask: np.ndarray, radius: int) -> np.ndarray:
    """(H, W) bool morphological closing with a disc; padded so the frame border does not glue ink to it."""
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1,) * 2)
    pad = radius + 1
    padded = np.pad(mask.astype(np.uint8), pad)
    return cv2.morphologyEx(padded, cv2.MORPH_CLOSE, kernel)[pad:-pad, pad:-pad] > 0


def past_margin(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool mask grown by a disc of MARGIN_PX: where the soft edge of its ink may still reach."""
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * MARGIN_PX + 1,) * 2)
    return cv2.dilate(mask.astype(np.uint8), disc) > 0


def bone_touched(mask: np.ndarray, touch: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """(H, W) bool the 8-connected components of mask that the (H, W) bool bone pixels touch; warnings.

    No bone touching any component (a pose far off the drawing) keeps the largest one, with a warning.
    """
    labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
    if n == 0:
        return mask.copy(), []
    ids = np.unique(labels[touch & mask])
    ids = ids[ids > 0]
    if len(ids) == 0:
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        return labels == int(np.argmax(sizes)), ["no bone touches the drawing; kept its largest part (check the pose)"]
    return np.isin(labels, ids), []


def strokes_near_bones(untouched: np.ndarray, near: np.ndarray, min_area: float) -> tuple[np.ndarray, int]:
    """((H, W) bool, their count): the 8-connected components of the (H, W) bool ink no bone touches that lie within a body's
    reach of a bone (NEAR_SHARE of their pixels in the (H, W) bool `near`) and are strokes, not specks or dots (at
    least min_area pixels, ELONGATION times longer than wide): the pieces of an outline drawn in separate strokes
    beside its limb's bone."""
    labels, n = ndimage.label(untouched, structure=np.ones((3, 3), bool))
    if n == 0:
        return np.zeros_like(untouched), 0
    area = np.bincount(labels.ravel(), minlength=n + 1)
    inside = np.bincount(labels[near], minlength=n + 1)
    # a stroke is long for its width: its area is many times that of the widest disc it holds (a dot is not)
    width = np.zeros(n + 1)
    np.maximum.at(width, labels.ravel(), cv2.distanceTransform(untouched.astype(np.uint8), cv2.DIST_L2, 5).ravel())
    keep = (area >= min_area) & (inside >= NEAR_SHARE * area) & (area >= ELONGATION * 4.0 * width ** 2)
    keep[0] = False
    return keep[labels], int(keep.sum())


def fill_insides(ink: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(H, W) bool ink with its insides filled: enclosed regions, and regions the image border cuts open that
    bones run through (points: (n, 2) float64 samples along the bones, x y pixels), except the page itself,
    the largest region touching the border."""
    filled = ndimage.binary_fill_holes(ink)
    labels, n = ndimage.label(~filled)
    if n <= 1:
        return filled
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    border = border[border > 0]
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    page = border[np.argmax(sizes[border])]
    counts = bone_crossings(labels, n, points)
    cut_open = [int(r) for r in border if r != page and counts[r] >= MIN_BONE_SAMPLES]
    return filled | np.isin(labels, cut_open) if cut_open else filled


def bone_crossings(labels: np.ndarray, n: int, points: np.ndarray) -> np.ndarray:
    """(n + 1,) int64: per label of a (H, W) int labelling (0 = none), the bone samples (points: (m, 2) float64
    x y pixels) that lie clear of its edge (5 x 5 erosion): several of them mean a bone runs through it."""
    clear = cv2.erode((labels > 0).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    row, col = _pixels(points, labels.shape)
    return np.bincount(labels[row, col][clear[row, col]], minlength=n + 1)


def _pixels(points: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) int arrays of the (m, 2) x y pixel points that fall inside an image of `shape` (H, W)."""
    col, row = np.round(points[:, 0]).astype(int), np.round(points[:, 1]).astype(int)
    ok = (col >= 0) & (col < shape[1]) & (row >= 0) & (row < shape[0])
    return row[ok], col[ok]


def enclose_broken(ink: np.ndarray, inside: np.ndarray, points: np.ndarray, radius: int) -> tuple[np.ndarray, int]:
    """Insides of outlines drawn with breaks wider than the closing's: ((H, W) bool, how many).

    ink: (H, W) bool ink; inside: (H, W) bool what the finer closing already filled; points: (m, 2) float64 bone
    samples, x y pixels. A region of paper that the ink encloses once gaps up to `radius` pixels are closed, and
    that a bone runs through the middle of, is a body part outlined in broken strokes (the inside of a belly
    drawn as dashes). The page is crossed by no bone; background seen between limbs (between a stick arm and the
    head) at most along its edge, where a bone drawn beside its stroke runs: the bone must reach at least
    MIDDLE_SHARE of the region's greatest depth. Returned with the closing's bridges across its gaps, so the
    outline's pieces around it are one component. The wider closing decides nothing else: limbs a few pixels
    apart stay apart.
    """
    wide = closing(ink, radius)
    labels, n = ndimage.label(ndimage.binary_fill_holes(wide) & ~wide & ~inside)
    if n == 0:
        return np.zeros_like(ink), 0
    depth = cv2.distanceTransform((labels > 0).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    deepest = ndimage.maximum(depth, labels, np.arange(n + 1))
    row, col = _pixels(points, ink.shape)
    on_bone = np.zeros(n + 1)
    np.maximum.at(on_bone, labels[row, col], depth[row, col])
    crossed = bone_crossings(labels, n, points) >= MIN_BONE_SAMPLES
    kept = np.nonzero(crossed[1:] & (on_bone[1:] >= MIDDLE_SHARE * np.asarray(deepest)[1:]))[0] + 1
    regions = np.isin(labels, kept)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1,) * 2)
    bridges = (cv2.dilate(regions.astype(np.uint8), disc) > 0) & wide
    return regions | bridges, len(kept)


def _count(mask: np.ndarray) -> int:
    """Number of 4-connected components of a (H, W) bool mask."""
    return int(ndimage.label(mask)[1])


def _cutout(rgba: np.ndarray, touch: np.ndarray) -> Foreground:
    """Foreground of a (H, W, 4) straight-alpha cut-out: its alpha, over a white page."""
    alpha = rgba[..., 3]
    mask, warnings = bone_touched(alpha > 0, touch)
    coverage = np.where(mask, alpha, 0.0).astype(np.float32)
    holes = ndimage.binary_fill_holes(mask) & ~mask
    return Foreground(
        mask=mask, coverage=coverage, colour=rgba[..., :3].copy(), paper=np.ones_like(rgba[..., :3]),
        holes=holes, n_holes=_count(holes), warnings=warnings,
    )


@dataclass
class Page:
    """How far every pixel of a drawing is from its paper, and the thresholds the page's noise sets."""

    paper: Paper
    delta: np.ndarray  # (H, W) float32 ΔE*ab of the drawing from the paper
    smooth_delta: np.ndarray  # (H, W) float32 the same after a BLUR_SIGMA blur of the drawing (grain averaged)
    ink_delta: float  # ΔE*ab above which a pixel is drawn
    paper_delta: float  # ΔE*ab below which a pixel on the soft edge is paper


def read_page(rgb: np.ndarray) -> Page:
    """The paper under a (H, W, 3) float32 sRGB drawing and every pixel's colour distance from it."""
    lab = to_lab(rgb)
    paper = estimate_paper(rgb, lab)
    return Page(
        paper=paper, delta=delta_e(lab, paper.lab),
        smooth_delta=delta_e(to_lab(cv2.GaussianBlur(rgb, (0, 0), BLUR_SIGMA)), paper.lab),
        ink_delta=max(INK_DELTA_E, NOISE_FACTOR * paper.noise),
        paper_delta=max(MIN_PAPER_DELTA_E, PAPER_FACTOR * paper.noise),
    )


def is_cutout(rgba: np.ndarray) -> bool:
    """Whether a (H, W, 4) drawing has real transparency: a significant share of pixels not fully opaque."""
    return float((rgba[..., 3] < 1.0 - 1.0 / 255).mean()) > TRANSPARENT_SHARE


def foreground_from_mask(drawing: np.ndarray, mask: np.ndarray) -> Foreground:
    """Foreground of a (H, W, C) float32 drawing whose (H, W) bool mask is given (a manual mask): its soft edge.

    The mask stays exactly as given (it is what `inbetween masks` writes back). Coverage is read from the
    drawing on the mask's page-facing fringe and up to MARGIN_PX past it: a mask painted tight along the
    outline, cutting its outer half, keeps the stroke's drawn width; paper there stays transparent.
    """
    rgba = to_rgba(drawing)
    mask = np.asarray(mask, bool)
    holes = ndimage.binary_fill_holes(mask) & ~mask
    if is_cutout(rgba):
        return Foreground(
            mask=mask.copy(), coverage=np.where(mask, rgba[..., 3], 0.0).astype(np.float32),
            colour=rgba[..., :3].copy(), paper=np.ones_like(rgba[..., :3]), holes=holes, n_holes=_count(holes),
        )
    rgb = np.ascontiguousarray(rgba[..., :3])
    page = read_page(rgb)
    sealed = closing(page.smooth_delta > page.ink_delta, close_radius(box_size(mask))) & mask  # the character's size
    reach = past_margin(mask) & ~holes
    coverage, colour = unmix(
        rgb, page.paper.rgb, mask, reach, page.delta > page.ink_delta, sealed, page.delta, page.ink_delta,
        page.paper_delta,
    )
    return Foreground(
        mask=mask.copy(), coverage=coverage, colour=colour, paper=page.paper.rgb, holes=holes, n_holes=_count(holes),
    )


def segment_foreground(drawing: np.ndarray, pose: np.ndarray, skeleton: Skeleton) -> Foreground:
    """Foreground of a (H, W, C) float32 drawing (C = 1..4, straight alpha) at a (J, 3) pose, pixels."""
    rgba = to_rgba(drawing)
    shape = rgba.shape[:2]
    touch = bone_capsules(shape, pose, skeleton, BONE_TOUCH_PX)
    if is_cutout(rgba):
        return _cutout(rgba, touch)
    rgb = np.ascontiguousarray(rgba[..., :3])
    page = read_page(rgb)
    points, owner = bone_samples(pose, skeleton)
    r = close_radius(shape)
    drawn = _silhouette(page, pose, skeleton, touch, points, r)
    # gaps are sealed by the character's size, not its page's: a drawing on a wide margin (a scan, a canvas grown
    # for the motion) would otherwise glue a limb to the body across the gap between them. The box is the final
    # mask's (past_margin of the silhouette; its holes lie inside it).
    own = close_radius(box_size(past_margin(drawn.silhouette)))
    if own < r:
        r, drawn = own, _silhouette(page, pose, skeleton, touch, points, own)
    crossed = bone_capsules(shape, pose, skeleton, CROSS_PX)
    holes = find_holes(drawn.silhouette, drawn.sealed, crossed, drawn.near, points, drawn.reach[owner], min_radius=r,
                       grazed=touch)
    solid = drawn.silhouette & ~holes
    mask = past_margin(solid)
    coverage, colour = unmix(
        rgb, page.paper.rgb, solid, mask, page.delta > page.ink_delta, drawn.sealed, page.delta, page.ink_delta,
        page.paper_delta,
    )
    holes = holes & ~mask
    return Foreground(
        mask=mask, coverage=coverage, colour=colour, paper=page.paper.rgb, holes=holes, n_holes=_count(holes),
        warnings=drawn.warnings,
    )


class _Drawn(NamedTuple):
    """What the strokes sealed at one radius make of a drawing (segment_foreground's first part)."""

    sealed: np.ndarray  # (H, W) bool ink with its gaps closed
    silhouette: np.ndarray  # (H, W) bool the character, insides filled, before its holes
    near: np.ndarray  # (H, W) bool within each bone's wall reach
    reach: np.ndarray  # (B,) float64 each bone's wall reach, pixels
    warnings: list[str]


def _silhouette(page: Page, pose: np.ndarray, skeleton: Skeleton, touch: np.ndarray, points: np.ndarray,
                r: int) -> _Drawn:
    """The silhouette of a read page (read_page) with its strokes' gaps sealed by a disc of radius r px; touch:
    (H, W) bool the bones' thin capsules, points: bone_samples' points."""
    shape = page.delta.shape[:2]
    sealed = closing(page.smooth_delta > page.ink_delta, r)
    filled = fill_insides(sealed, points)
    broken, n_broken = enclose_broken(sealed, filled, points, BROKEN_SCALE * r)
    silhouette, warnings = bone_touched(filled | broken, touch)
    if n_broken:
        warnings.append(f"closed gaps of up to {BROKEN_SCALE * r} px in the outline around {n_broken} inside(s) a "
                        "bone runs through (an outline drawn in broken strokes); check the foreground preview")
    radii = bone_radii(silhouette, pose, skeleton)
    reach = WALL_SCALE * radii + WALL_MARGIN_PX
    near = bone_capsules(shape, pose, skeleton, reach)
    ends = pose[np.asarray(skeleton.bones)][..., :2]  # (B, 2, 2): a limb's outline lies about LIMB_SHARE of its bone's
    # length from it however its inside was drawn (an outline in separate strokes leaves the radii at a stroke's width)
    limb = LIMB_SHARE * np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    outline = bone_capsules(shape, pose, skeleton, np.maximum(reach, limb))
    strokes, kept = strokes_near_bones((filled | broken) & ~silhouette, outline, STROKE_AREA * r * r)
    if kept:
        silhouette = silhouette | strokes
        warnings.append(f"kept {kept} stroke(s) that no bone touches but that lie within a body's reach "
                        "of one (an outline drawn in separate strokes); check the foreground preview")
    return _Drawn(sealed, silhouette, near, reach, warnings)
