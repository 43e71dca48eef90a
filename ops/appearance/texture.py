"""Per-face texture of a 2.5D template (§5.1).

The front sheet shows the keyframe drawing; a pocket face shows the other
keyframe where, deformed into the other keyframe's pose, it is visible
there, and is inpainted otherwise.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from ops.appearance.inpaint import Inpainter
from ops.appearance.render import affine_maps, rasterize_ids
from ops.shotio.image_io import to_rgba
from ops.types import Template, TexturedTemplate

VISIBLE_FRACTION = 0.5  # a pocket face takes the other keyframe's texture if this much of it is visible there
SAMPLES_PER_SIDE = 4  # k: a face's visibility is measured at the k*k centroids of its regular subdivision
MARGIN = 3  # pixels: back texture extended past the pockets so bilinear samples at their edges stay opaque


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


def _pocket_samples(template: Template, deformed_to_other: np.ndarray, shape: tuple[int, int]):
    """Pocket raster at rest -> (ids (H, W) int32, qx, qy (H, W) float32 position in the other keyframe)."""
    pockets = np.nonzero(template.face_layer > 0)[0]
    ids = rasterize_ids(template.rest, template.faces, pockets, shape, 1)
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


def texture_template(template: Template, weights: np.ndarray, drawing: np.ndarray, foreground: np.ndarray,
                     other_drawing: np.ndarray, other_occlusion: list[np.ndarray], other_foreground: np.ndarray,
                     deformed_to_other: np.ndarray, inpainter: Inpainter) -> TexturedTemplate:
    """Drawings (H, W, C), masks (H, W) bool, deformed_to_other (n, 2) pixels -> TexturedTemplate."""
    shape = foreground.shape
    texture = to_rgba(drawing)
    texture[..., 3] = foreground.astype(np.float32)
    m = template.faces.shape[0]
    face_source = np.zeros(m, dtype=np.int64)
    back = np.zeros(shape + (4,), dtype=np.float32)
    back_inpainted = np.zeros(shape, dtype=bool)
    pockets = np.nonzero(template.face_layer > 0)[0]
    if pockets.size == 0:
        return TexturedTemplate(template, weights, face_source, texture, back, back_inpainted)

    visible = np.asarray(other_foreground, dtype=bool).copy()
    for occ in other_occlusion:
        visible &= ~np.asarray(occ, dtype=bool)
    tris = np.asarray(deformed_to_other, np.float64)[template.faces[pockets]]
    face_source[pockets] = np.where(visible_fraction(tris, visible) >= VISIBLE_FRACTION, 1, 2)

    ids, qx, qy = _pocket_samples(template, deformed_to_other, shape)
    covered = ids >= 0
    other_rgb = np.ascontiguousarray(to_rgba(other_drawing)[..., :3])
    remap = dict(interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    sampled = cv2.remap(other_rgb, qx, qy, borderValue=(0, 0, 0), **remap)
    seen = cv2.remap(visible.astype(np.float32), qx, qy, borderValue=0, **remap) >= 0.5
    # per pixel as well as per face: a source-1 face's samples that the other keyframe hides are inpainted too
    ok = covered & (face_source[np.maximum(ids, 0)] == 1) & seen
    holes = covered & ~ok
    context = np.where(ok[..., None], sampled, texture[..., :3])
    filled = np.asarray(inpainter(context.astype(np.float32), holes), dtype=np.float32)
    back[..., :3] = np.where(ok[..., None], sampled, filled)
    back[..., 3] = 1.0
    back[~covered] = 0.0
    back_inpainted[:] = holes
    if covered.any():
        _extend_margin(back, back_inpainted, covered, MARGIN)
    return TexturedTemplate(template, weights, face_source, texture, back, back_inpainted)
