"""Per-face texture of a 2.5D template (§5.1).

In each occlusion region, the layer in front at the keyframe's own pose (by
bounded biharmonic depth averaged over the layer) shows the drawing: its
colour unmixed from the paper, with the drawing's coverage as alpha, so soft
edges and outlines keep their drawn width. A hidden face shows the other
keyframe where, deformed into the other keyframe's pose, it is visible there,
and is inpainted otherwise; where it lands on the other keyframe's paper it is
as transparent as the paper (a pocket is the whole near limb's shape, the far
limb behind it is often thinner).
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from ops.appearance.inpaint import Inpainter, inpaint
from ops.appearance.layers import layer_depth, layer_groups, rest_stacks
from ops.appearance.render import affine_maps, rasterize_ids
from ops.geometry.mesh import vertex_components
from ops.types import RefinedMasks, Template, TexturedTemplate

VISIBLE_FRACTION = 0.5  # a pocket face takes the other keyframe's texture if this much of it is visible there
SAMPLES_PER_SIDE = 4  # k: a face's visibility is measured at the k*k centroids of its regular subdivision
MARGIN = 3  # pixels: back texture extended past the pockets so bilinear samples at their edges stay opaque
SHEET_EDGE_PX = 2  # a sheet's pixels this near its edge are not what its hidden stretch is inpainted from


def subdivision_barycentrics(k: int) -> np.ndarray:
    """(k*k, 3) barycentric centroids of the k*k congruent sub-triangles (uniform area samples)."""
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    up = (i + j) <= k - 1
    down = (i + j) <= k - 2
    u = np.concatenate([(i[up] + 1 / 3) / k, (i[down] + 2 / 3) / k])
    v = np.concatenate([(j[up] + 1 / 3) / k, (j[down] + 2 / 3) / k])
    return np.stack([1 - u - v, u, v], axis=1)


def visible_fraction(tris: np.ndarray, visible: np.ndarray, k: int = SAMPLES_PER_SIDE) -> np.ndarray:
    """tris (m, 3, 2) pixels, visible (H, W) bool -> (m,) fraction of each triangle's area on visible pixels."""
    bary = subdivision_barycentrics(k)
    pts = np.einsum("sk,mkd->msd", bary, tris)  # (m, s, 2)
    vals = ndimage.map_coordinates(visible.astype(np.float32), [pts[..., 1].ravel(), pts[..., 0].ravel()],
                                   order=1, mode="constant", cval=0.0)
    return vals.reshape(pts.shape[:2]).mean(axis=1)


def character_rgba(masks: RefinedMasks) -> np.ndarray:
    """(H, W, 4) float32 straight RGBA of the character alone: its colour unmixed from the paper, alpha = coverage."""
    return np.concatenate([masks.colour, masks.coverage[..., None]], axis=2).astype(np.float32)


def drawing_faces(template: Template, weights: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(m,) bool: the faces that show the drawing at the keyframe's own pose (J, 3) (stack_ranks 0)."""
    return stack_ranks(template, weights, pose) == 0


def stack_ranks(template: Template, weights: np.ndarray, pose: np.ndarray, stack: np.ndarray | None = None
                ) -> np.ndarray:
    """(m,) int64 each face's place front to back among the faces on it at rest, at the keyframe's pose (J, 3):
    0 shows the drawing, 1 + l is back level l.

    Of the faces on each other at rest (an occlusion region's front-sheet face and its pocket's copy, or three
    where regions are nested), the one of the layer with the smallest bounded biharmonic depth averaged over
    the layer is in front (§5.1; a tie goes to the front sheet): it shows the drawing. The hidden ones are
    numbered front to back: each level has a back texture of its own, since two hidden layers can lie at one
    rest pixel. Outside the regions the front sheet shows it. stack: rest_stacks(template), when the caller has it.
    """
    F, layer = template.faces, template.face_layer
    depth = layer_depth((weights @ np.asarray(pose, np.float64)[:, 2])[F].mean(axis=1), layer_groups(template))
    stack = rest_stacks(template) if stack is None else stack
    order = np.lexsort((layer, depth, stack))  # by stack, then front to back
    first = np.r_[True, stack[order][1:] != stack[order][:-1]]
    start = np.maximum.accumulate(np.where(first, np.arange(len(order)), 0))
    rank = np.empty(len(F), np.int64)
    rank[order] = np.arange(len(order)) - start  # 0 = in front
    return rank


def _back_samples(template: Template, back: np.ndarray, deformed_to_other: np.ndarray, shape: tuple[int, int]):
    """Hidden faces `back` (k,) rasterized at rest -> (ids (H, W) int32, qx, qy (H, W) float32 in the other keyframe)."""
    ids = rasterize_ids(template.rest, template.faces, back, shape, 1)
    A = affine_maps(template.rest[template.faces], np.asarray(deformed_to_other, np.float64)[template.faces])
    ys, xs = np.nonzero(ids >= 0)
    a = A[ids[ys, xs]]
    qx = np.full(shape, -1e4, dtype=np.float32)
    qy = np.full(shape, -1e4, dtype=np.float32)
    qx[ys, xs] = a[:, 0, 0] * xs + a[:, 0, 1] * ys + a[:, 0, 2]
    qy[ys, xs] = a[:, 1, 0] * xs + a[:, 1, 1] * ys + a[:, 1, 2]
    return ids, qx, qy


def _extend_margin(back: np.ndarray, inpainted: np.ndarray, covered: np.ndarray, margin: int):
    """Copy the nearest covered pixel into a margin-wide ring around the pockets (in place)."""
    dist, (iy, ix) = ndimage.distance_transform_edt(~covered, return_indices=True)
    ring = (~covered) & (dist <= margin)
    back[ring] = back[iy[ring], ix[ring]]
    inpainted[ring] = inpainted[iy[ring], ix[ring]]


def texture_template(template: Template, weights: np.ndarray, own: RefinedMasks, other: RefinedMasks | None,
                     pose: np.ndarray, deformed_to_other: np.ndarray | None, inpainter: Inpainter) -> TexturedTemplate:
    """Both keyframes' masks (their coverage and unmixed colour are the drawings), the keyframe's pose (J, 3),
    the template deformed to the other keyframe's pose (n, 2) pixels -> TexturedTemplate (the layer in front at
    the keyframe shows the drawing). No other keyframe (None, a one-drawing shot): every hidden face is inpainted.

    The hidden faces of each back level (stack_ranks) get a back texture of their own, side by side in
    TexturedTemplate.back_texture: level l's rest pixel (x, y) is its pixel (x + l W, y)."""
    texture = character_rgba(own)
    stack = rest_stacks(template)
    level = stack_ranks(template, weights, pose, stack) - 1  # -1: shows the drawing
    face_source = np.where(level < 0, 0, 1).astype(np.int64)
    back_level = np.maximum(level, 0)
    backs, inpainted = [], []
    context = texture  # what a level's holes are inpainted from: the drawing, under it the levels above
    nested = np.bincount(stack)[stack] >= 3  # (m,) faces of a three-layer stack
    sheet = vertex_components(len(template.rest), template.faces)[template.faces[:, 0]] if nested.any() else None
    for lv in range(max(int(level.max()) + 1, 1)):
        b, i = _back_layer(template, np.flatnonzero(level == lv), face_source, context, other, deformed_to_other,
                           inpainter)
        if nested.any():
            _inpaint_by_sheet(template, np.flatnonzero((level == lv) & nested), sheet, level, b, i, backs, texture,
                              inpainter)
        backs.append(b)
        inpainted.append(i)
        # the chest under both crossed forearms continues the chest under each one, not the forearms' ink
        context = np.where((b[..., 3] > 0)[..., None], b, context)
    return TexturedTemplate(template, weights, face_source, texture, np.concatenate(backs, axis=1),
                            np.concatenate(inpainted, axis=1), back_level)


def _inpaint_by_sheet(template: Template, faces: np.ndarray, sheet: np.ndarray, level: np.ndarray, back: np.ndarray,
                      inpainted: np.ndarray, above: list[np.ndarray], texture: np.ndarray, inpainter: Inpainter):
    """Refill, in place, the inpainted pixels of hidden faces (k,) of a three-layer stack in one back level's
    texture back (H, W, 4) and inpainted (H, W) bool, each sheet (a connected piece of the mesh, sheet (m,)) from
    what that sheet shows elsewhere: the drawing where it is in front (level (m,) -1), the levels above
    (`above`, (H, W, 4) each) where it is hidden. The lower forearm's stretch under the top one is then the
    forearm's colour, not the chest's or the top forearm's around it."""
    shape = texture.shape[:2]
    ids = rasterize_ids(template.rest, template.faces, faces, shape, 1)
    for s in np.unique(sheet[faces]):
        hole = (ids >= 0) & (sheet[np.maximum(ids, 0)] == s) & inpainted
        if not hole.any():
            continue
        own = np.flatnonzero((sheet == s) & (level < 0))
        known = np.zeros(shape, bool)
        image = np.zeros(shape + (3,), np.float32)
        cover = np.zeros(shape, np.float32)
        shown = rasterize_ids(template.rest, template.faces, own, shape, 1) >= 0
        image[shown], cover[shown], known[shown] = texture[shown][:, :3], texture[shown][:, 3], True
        for lv, b in enumerate(above):
            hidden = np.flatnonzero((sheet == s) & (level == lv))
            there = (rasterize_ids(template.rest, template.faces, hidden, shape, 1) >= 0) & (b[..., 3] > 0) & ~known
            image[there], cover[there], known[there] = b[there][:, :3], b[there][:, 3], True
        # the pixels along the sheet's edge hold the ink of whatever covers it there (the top forearm's outline
        # where the lower one passes under it): inpainted from them, the stretch would take that ink's colour
        known &= cv2.erode(known.astype(np.uint8), np.ones((3, 3), np.uint8), iterations=SHEET_EDGE_PX) > 0
        if not known.any():
            continue  # a sheet shown nowhere: the level's own inpainting stands
        filled = inpaint(inpainter, image, ~known, cover)
        back[hole, :3] = filled[hole]


def _back_layer(template: Template, hidden: np.ndarray, face_source: np.ndarray, texture: np.ndarray,
                other: RefinedMasks | None, deformed_to_other: np.ndarray | None, inpainter: Inpainter
                ) -> tuple[np.ndarray, np.ndarray]:
    """The back texture (H, W, 4) float32 and its inpainted pixels (H, W) bool of hidden faces (k,) that do not lie
    on each other at rest (one back level); sets their face_source (m,) to 1 (the other keyframe) or 2 (inpainted)."""
    shape = texture.shape[:2]
    back = np.zeros(shape + (4,), dtype=np.float32)
    back_inpainted = np.zeros(shape, dtype=bool)
    if hidden.size == 0:
        return back, back_inpainted
    if other is None:  # one drawing: no other keyframe shows the hidden layers, so all of them are inpainted
        face_source[hidden] = 2
        covered = _back_samples(template, hidden, template.rest, shape)[0] >= 0
        back[..., :3] = inpaint(inpainter, texture[..., :3].astype(np.float32), covered, texture[..., 3])
        back[..., 3] = 1.0
        back[~covered] = 0.0
        back_inpainted[:] = covered
        _extend_margin(back, back_inpainted, covered, MARGIN)
        return back, back_inpainted

    visible = np.asarray(other.foreground, dtype=bool).copy()
    for occ in other.occlusion:
        visible &= ~np.asarray(occ, dtype=bool)
    tris = np.asarray(deformed_to_other, np.float64)[template.faces[hidden]]
    face_source[hidden] = np.where(visible_fraction(tris, visible) >= VISIBLE_FRACTION, 1, 2)

    ids, qx, qy = _back_samples(template, hidden, deformed_to_other, shape)
    covered = ids >= 0
    other_rgb = np.ascontiguousarray(other.colour, dtype=np.float32)
    remap = dict(interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    sampled = cv2.remap(other_rgb, qx, qy, borderValue=(0, 0, 0), **remap)
    seen = cv2.remap(visible.astype(np.float32), qx, qy, borderValue=0, **remap) >= 0.5
    # per pixel as well as per face: a source-1 face's samples that the other keyframe hides are inpainted too
    ok = covered & (face_source[np.maximum(ids, 0)] == 1) & seen
    # a hidden point the deformation carries onto the other keyframe's paper is no part of the character
    # there: it is as transparent as the other drawing's coverage (the pocket's edge past a smaller far limb)
    inside_other = np.asarray(other.foreground, dtype=np.float32)
    cov = np.clip(cv2.remap(np.asarray(other.coverage, np.float32), qx, qy, borderValue=0, **remap), 0.0, 1.0)
    absent = covered & (cv2.remap(inside_other, qx, qy, borderValue=0, **remap) < 0.5)
    holes = covered & ~ok & ~absent
    context = np.where(ok[..., None], sampled, texture[..., :3])
    # what the context shows of the character (paper gives no colour): the other keyframe's where sampled
    context_cover = np.where(ok, cov, texture[..., 3]).astype(np.float32)
    filled = inpaint(inpainter, context.astype(np.float32), holes, context_cover)
    back[..., :3] = np.where((ok | absent)[..., None], sampled, filled)
    back[..., 3] = np.where(ok | absent, cov, 1.0)
    back[~covered] = 0.0
    back_inpainted[:] = holes
    if covered.any():
        _extend_margin(back, back_inpainted, covered, MARGIN)
    return back, back_inpainted
