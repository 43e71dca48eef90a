"""Contacts: where the bodies of two bones that are not neighbours touch along a shared stroke.

An arm hanging along the torso, a hand resting on a hip, legs standing together: the drawing separates the
parts by a stroke, the foreground merges them, and a mesh glued across the stroke drags the torso's side
along when the arm lifts (hand_on_hip). The skeleton rule (ops.segmentation.occlusion) sees only bodies
that overlap. Here the pixels between strokes go to bones (the nearest bone among those that hold their
compartment of the drawing), and a stroke with the bodies of two non-adjacent bones on its two sides is a
contact. The template is slit along it (ops.segmentation.slits, ops.geometry.mesh.cut_along), so the parts part when
the limb moves and stay sewn where they are one body.

An overlap region no thicker than the contact's band (thin_overlaps) is the same touch seen by the
skeleton rule: the hand's capsule dips into the hip. It hides nothing worth a pocket, and its pocket would
glue the hand to the hip again, so the slit replaces it.
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

from ops.segmentation.bones import bone_samples, segment_distance, thick_regions
from ops.types import Skeleton

STROKE_PX, STROKE_CONTRAST = 3, 0.12  # a stroke: darker by this (luminance) than the brightest within STROKE_PX
SIDE_PX = 3  # a stroke pixel's sides: the pixels between strokes within this distance
MIN_CONTACT_PX = 8  # shorter contacts are a corner touching, not a shared stroke
HOLD_SHARE = 0.25  # a bone holds the compartment between strokes that has this share of its length
FAR_PX = 1e4  # distance added to a bone outside the compartments it holds
FOUR = ndimage.generate_binary_structure(2, 1)
THIN_SHARE = 0.95  # an overlap region with this share of its pixels within SIDE_PX + 1 of a contact is one


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
    dist += _compartment_penalty(inside, pose, skeleton)[:, ys, xs]
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
        if len(longest_path(skeletonize(piece))) >= MIN_CONTACT_PX:
            pieces.append(piece)
    return pieces


def thin_overlaps(regions: list[np.ndarray], contacts: list[np.ndarray]) -> np.ndarray:
    """(R,) bool: which (H, W) bool overlap regions lie along the (H, W) bool contacts, THIN_SHARE of their
    pixels within SIDE_PX + 1 of one (the band a contact's two sides span)."""
    if not regions or not contacts:
        return np.zeros(len(regions), bool)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * SIDE_PX + 3,) * 2)
    band = cv2.dilate(np.any(contacts, axis=0).astype(np.uint8), disc) > 0
    return np.array([(r & band).sum() >= THIN_SHARE * max(int(r.sum()), 1) for r in regions], bool)


def _compartment_penalty(inside: np.ndarray, pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(B, H, W) float64 added distance: 0 inside the compartments a bone holds, FAR elsewhere (0 everywhere
    for a compartment that holds no bone).

    A compartment is a 4-connected piece of the (H, W) bool pixels between strokes. A bone holds one when at
    least HOLD_SHARE of its length lies in it: a hand joint drawn on the torso's outline dips the forearm's
    tip into the torso, but the torso's pixels near it still belong to the torso's bones.
    """
    labels, n = ndimage.label(inside, structure=FOUR)
    points, owner = bone_samples(pose, skeleton, step=1.0)
    h, w = inside.shape
    xy = np.round(points).astype(np.int64)
    ok = (xy[:, 0] >= 0) & (xy[:, 0] < w) & (xy[:, 1] >= 0) & (xy[:, 1] < h)
    comp = np.zeros(len(points), np.int64)
    comp[ok] = labels[xy[ok, 1], xy[ok, 0]]
    B = len(skeleton.bones)
    counts = np.zeros((B, n + 1))
    np.add.at(counts, (owner, comp), 1.0)
    holds = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1.0) >= HOLD_SHARE
    holds[:, 0] = False
    held = holds.any(axis=0)
    allowed = holds | ~held[None]  # (B, n + 1): compartments nobody holds are open to every bone
    return np.where(allowed[:, labels], 0.0, FAR_PX)


def longest_path(pixels: np.ndarray) -> np.ndarray:
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
