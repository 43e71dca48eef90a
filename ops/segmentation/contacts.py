"""Contacts: where the bodies of two bones that are not neighbours touch without overlapping.

An arm hanging along the torso, a hand resting on a hip, legs standing together: the drawing separates the
parts by a shared stroke, the foreground merges them, and a mesh glued across the stroke drags the torso's
side along when the arm lifts (hand_on_hip). The skeleton rule (ops.segmentation.occlusion) sees only bodies
that overlap. Here every foreground pixel goes to the bone whose body surface is nearest (body_cells), and
where the cells of two non-adjacent bones meet, a band CONTACT_BAND_PX wide on either side of the
border is a contact. Each piece of a band outside the overlap regions becomes an occlusion region of its own in front of the
nearer bone, with exactly two T-junctions at its ends: one long side is sewn to the front and the other to the
pocket, so the mesh is cut along one side of the shared stroke, and the cut search (ops.geometry.topology)
picks which side.
Bones joined through one short bone (spine - clavicle - upper arm) meet around it: that bone's body is left
out of their contact, as of their overlap.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from skimage.morphology import skeletonize

from ops.geometry.mesh import project_to_polyline

from ops.segmentation.bones import segment_distance, thick_regions
from ops.types import Skeleton

STROKE_PX, STROKE_CONTRAST = 3, 0.12  # a stroke: darker by this (luminance) than the brightest within STROKE_PX
SIDE_PX = 3  # a stroke pixel's sides: the pixels between strokes within this distance
MIN_CONTACT_PX = 8  # shorter contacts are a corner touching, not a shared stroke
AVOID_PX = 3  # a slit keeps this far from the occlusion regions' boundaries (mesh constraints)
SLIT_STEP_PX = 3  # spacing of a slit's polyline vertices along the contact
REACH_OUTLINE_PX = 6.0  # a slit's end this close to the outline is carried on to it


def stroke_contacts(drawing: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
                    ) -> list[np.ndarray]:
    """(H, W) bool contacts of a (H, W, C) float32 drawing: stroke pixels inside the (H, W) bool foreground with
    the bodies of two bones that are not neighbours on their two sides, in pieces at least MIN_CONTACT_PX long.

    A stroke is a pixel darker than the brightest within STROKE_PX by STROKE_CONTRAST (ink on paper, a dark
    outline on a colour fill, pencil). The pixels between strokes go to their nearest bone. Bones joined
    through one short bone (spine - clavicle - upper arm) meet around it: that bone's body is left out, so
    the arm stays attached at the shoulder.
    """
    rgb = np.asarray(drawing, np.float32)[..., :3] if drawing.ndim == 3 else np.asarray(drawing, np.float32)[..., None]
    lum = rgb.mean(axis=-1)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * STROKE_PX + 1,) * 2)
    stroke = foreground & ((cv2.dilate(lum, kernel) - lum) > STROKE_CONTRAST)
    inside = foreground & ~stroke
    ys, xs = np.nonzero(inside)
    if len(xs) == 0 or len(skeleton.bones) < 2:
        return []
    p = np.stack([xs, ys], axis=1).astype(np.float64)
    dist = np.stack([segment_distance(p, pose[a, :2], pose[b, :2]) for a, b in skeleton.bones])
    owner = np.argmin(dist, axis=0)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * SIDE_PX + 1,) * 2)
    near = np.zeros((len(skeleton.bones),) + foreground.shape, bool)
    for bone in np.unique(owner):
        cell = np.zeros(foreground.shape, np.uint8)
        cell[ys[owner == bone], xs[owner == bone]] = 1
        near[bone] = (cv2.dilate(cell, disc) > 0) & stroke
    adjacent = skeleton.adjacent_bones()
    thick = thick_regions(foreground, pose, skeleton)
    touching = np.zeros(foreground.shape, bool)
    present = [b for b in range(len(near)) if near[b].any()]
    for i in present:
        for j in present:
            if j <= i or adjacent[i, j]:
                continue
            both = near[i] & near[j]
            between = adjacent[i] & adjacent[j]
            if between.any():
                both &= ~thick[between].any(axis=0)
            touching |= both
    labels, n = ndimage.label(touching, structure=np.ones((3, 3), bool))
    pieces = []
    for lab in range(1, n + 1):
        piece = labels == lab
        if len(_longest_path(skeletonize(piece))) >= MIN_CONTACT_PX:
            pieces.append(piece)
    return pieces


def _longest_path(pixels: np.ndarray) -> np.ndarray:
    """(k, 2) float64 (x, y) of the longest shortest path through (H, W) bool 8-connected one-pixel-wide pixels."""
    ys, xs = np.nonzero(pixels)
    index = -np.ones(pixels.shape, np.int64)
    index[ys, xs] = np.arange(len(xs))
    rows, cols, lengths = [], [], []
    h, w = pixels.shape
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        y2, x2 = ys + dy, xs + dx
        ok = (y2 < h) & (x2 >= 0) & (x2 < w)
        j = np.full(len(xs), -1)
        j[ok] = index[y2[ok], x2[ok]]
        ok &= j >= 0
        rows.append(np.nonzero(ok)[0])
        cols.append(j[ok])
        lengths.append(np.full(ok.sum(), np.hypot(dy, dx)))
    n = len(xs)
    A = coo_matrix((np.concatenate(lengths), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    far = int(np.argmax(np.nan_to_num(dijkstra(A, directed=False, indices=0), posinf=-1)))
    dist, pred = dijkstra(A, directed=False, indices=far, return_predecessors=True)
    end = int(np.argmax(np.nan_to_num(dist, posinf=-1)))
    path = [end]
    while pred[path[-1]] >= 0:
        path.append(int(pred[path[-1]]))
    return np.stack([xs[path], ys[path]], axis=1).astype(np.float64)


def slit_of(piece: np.ndarray, avoid: np.ndarray, domain: list[np.ndarray]) -> np.ndarray | None:
    """(k, 2) float64 open polyline along a contact piece ((H, W) bool), CONTACT_BAND_PX clear of `avoid` (the
    occlusion regions: their boundaries are mesh constraints the slit must not cross), each end carried on to
    the domain's outline (closed polylines) when within REACH_OUTLINE_PX of it so the cut opens there; None
    when too little of the piece is left."""
    if avoid.any():
        piece = piece & ~ndimage.binary_dilation(avoid, iterations=AVOID_PX)
    labels, n = ndimage.label(piece, structure=np.ones((3, 3), bool))
    if n == 0:
        return None
    sizes = np.bincount(labels.ravel())[1:]
    piece = labels == 1 + int(np.argmax(sizes))
    path = _longest_path(skeletonize(piece))
    if len(path) < MIN_CONTACT_PX:
        return None
    path = path[:: SLIT_STEP_PX][:-1].tolist() + [path[-1].tolist()]
    ends = []
    for end in (path[0], path[-1]):
        best = None
        for L in domain:
            param, dist = project_to_polyline(np.asarray([end], np.float64), L)
            i, t = int(param[0]), float(param[0] % 1.0)
            foot = L[i] + t * (L[(i + 1) % len(L)] - L[i])
            if dist[0] <= REACH_OUTLINE_PX and (best is None or dist[0] < best[0]):
                best = (dist[0], foot)
        ends.append(None if best is None or best[0] < 0.5 else best[1].tolist())
    out = ([ends[0]] if ends[0] else []) + path + ([ends[1]] if ends[1] else [])
    return np.asarray(out, np.float64)
