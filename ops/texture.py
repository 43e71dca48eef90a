"""Depth weights and per-face texture of a 2.5D template (§5.1).

Depth: every vertex gets bounded biharmonic weights over the joints, so a
face's depth at any pose is the weighted joint depth. Texture: the front
sheet shows the keyframe drawing; a pocket face shows the other keyframe
where, deformed into the other keyframe's pose, it is visible there, and is
inpainted otherwise.
"""
from __future__ import annotations

import cv2
import igl
import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve

from .image_io import to_rgba
from .inpaint import Inpainter
from .render import affine_maps, rasterize_ids
from .types import Template, TexturedTemplate

BBW_MAX_ITER = 8  # active-set iterations: weights settle in a few, each costs a QP solve
VISIBLE_FRACTION = 0.5  # a pocket face takes the other keyframe's texture if this much of it is visible there
SAMPLES_PER_SIDE = 4  # k: a face's visibility is measured at the k*k centroids of its regular subdivision
MARGIN = 3  # pixels: back texture extended past the pockets so bilinear samples at their edges stay opaque


def vertex_components(n: int, faces: np.ndarray) -> np.ndarray:
    """(n,) int64 connected-component label per vertex (unreferenced vertices get their own)."""
    f = np.asarray(faces, dtype=np.int64)
    rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    adj = sp.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n))
    return connected_components(adj, directed=False)[1].astype(np.int64)


def harmonic_weights(V: np.ndarray, F: np.ndarray, b: np.ndarray, bc: np.ndarray) -> np.ndarray:
    """V (n, 2), F (m, 3), b (h,), bc (h, k) -> (n, k) harmonic interpolation of bc (cotangent Laplacian)."""
    L = igl.cotmatrix(V, F).tocsr()
    free = np.setdiff1d(np.arange(V.shape[0]), b)
    W = np.zeros((V.shape[0], bc.shape[1]))
    W[b] = bc
    if free.size:
        rhs = -(L[free][:, b] @ bc)
        sol = spsolve(L[free][:, free].tocsc(), rhs)
        W[free] = sol.reshape(free.size, -1)
    return W


def _solve_weights(V: np.ndarray, F: np.ndarray, b: np.ndarray, bc: np.ndarray) -> np.ndarray:
    """Bounded biharmonic weights (n, k), or harmonic ones where bbw fails (non-manifold seams, QP failure)."""
    if bc.shape[1] == 1:
        return np.ones((V.shape[0], 1))
    try:
        W = igl.bbw(V, F, b, bc, partition_unity=False, max_iter=BBW_MAX_ITER)
        W = np.asarray(W, dtype=np.float64)
        if W.shape == (V.shape[0], bc.shape[1]) and np.isfinite(W).all():
            return W
    except (RuntimeError, ValueError):
        pass
    # bbw's QP can fail on meshes with pockets sewn along part of their boundary; harmonic weights
    # share its boundary conditions and are bounded by the maximum principle, only less smooth.
    return harmonic_weights(V, F, b, bc)


def _normalize_rows(W: np.ndarray) -> np.ndarray:
    """(n, k) -> clipped to [0, 1] with rows summing to 1 (zero rows stay zero)."""
    W = np.clip(W, 0.0, 1.0)
    s = W.sum(axis=1, keepdims=True)
    return np.divide(W, s, out=np.zeros_like(W), where=s > 1e-12)


def depth_weights(template: Template) -> np.ndarray:
    """(n, J) float64 bounded biharmonic weights per joint, rows sum to 1 (handle rows = handle_weights)."""
    V = np.ascontiguousarray(template.rest, dtype=np.float64)
    F = np.ascontiguousarray(template.faces, dtype=np.int64)
    n, J = V.shape[0], template.handle_weights.shape[1]
    handles, first = np.unique(np.asarray(template.handles, dtype=np.int64), return_index=True)
    bc_all = np.asarray(template.handle_weights, dtype=np.float64)[first]
    if handles.size == 0:
        return np.full((n, J), 1.0 / J)
    comp = vertex_components(n, F)
    inside = np.isin(comp, comp[handles])
    sub = np.nonzero(inside)[0]
    local = np.full(n, -1, dtype=np.int64)
    local[sub] = np.arange(sub.size)
    Fs = local[F[inside[F[:, 0]]]]
    cols = np.nonzero(np.abs(bc_all).sum(axis=0) > 0)[0]  # joints no handle uses get weight 0 everywhere
    W = np.zeros((n, J))
    if Fs.shape[0]:
        Ws = _solve_weights(V[sub], Fs, local[handles], bc_all[:, cols])
        W[np.ix_(sub, cols)] = _normalize_rows(Ws)
    W[handles] = bc_all
    # vertices the handles cannot reach (other components, zero rows) follow their nearest handle
    orphan = np.nonzero(~inside | (W.sum(axis=1) < 0.5))[0]
    if orphan.size:
        d = ((V[orphan, None, :] - V[None, handles, :]) ** 2).sum(axis=2)
        W[orphan] = bc_all[d.argmin(axis=1)]
    return W


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
