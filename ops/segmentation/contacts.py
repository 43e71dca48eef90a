"""Contacts: where the bodies of two bones that are not neighbours touch along a shared stroke.

An arm hanging along the torso, a hand resting on a hip, legs standing together: the drawing separates the
parts by a stroke, the foreground merges them, and a mesh glued across the stroke drags the torso's side
along when the arm lifts (hand_on_hip). The skeleton rule (ops.segmentation.occlusion) sees only bodies
that overlap. Here the pixels between strokes go to bones (the nearest bone among those that hold their
compartment of the drawing), and a stroke with the bodies of two non-adjacent bones on its two sides is a
contact. The template is slit along it (ops.segmentation.slits, ops.geometry.mesh.cut_along), so the parts
part when the limb moves and stay sewn where they are one body.

Paint without ink (watercolour) has no stroke between a hand and the skirt it hangs beside, only a few
pixels of paper that the foreground closed over; that glued paper is a contact's stroke too.

An overlap region no thicker than the contact's band (thin_overlaps) is the same touch seen by the
skeleton rule: the hand's capsule dips into the hip. It hides nothing worth a pocket, and its pocket would
glue the hand to the hip again, so the slit replaces it.
Bones joined through one short bone (spine - clavicle - upper arm, torso - hip bone) meet around it: that
bone's body is left out of their contact, as of their overlap, and they touch only along the longer of the
two (an arm along the body), never across it (a waistband is where a torso and its hips are one body).
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from skimage.morphology import skeletonize

from ops.geometry.polygon import box_size
from ops.segmentation.bones import bone_samples, segment_distance, thick_regions
from ops.types import Skeleton

# Lengths below are for a drawing of REFERENCE_DIAG_PX diagonal, and grow with larger drawings (scale_of):
# a photographed crayon outline 10 px wide is one stroke, not two edges with a compartment inside.
REFERENCE_DIAG_PX = 363.0  # a 256 x 256 keyframe (362.04)
STROKE_PX, STROKE_CONTRAST = 3, 0.12  # a stroke: darker by this (luminance) than the brightest within STROKE_PX
SIDE_PX = 3  # a stroke pixel's sides: the pixels between strokes within this distance
RIM_PX = 2  # glued paper this near the paper outside is the outline's soft rim, not paper between bodies
MIN_CONTACT_PX = 8  # shorter contacts are a corner touching, not a shared stroke
ALONG_DEG = 45.0  # a contact between bodies joined around a short bone runs this close to the longer bone
TRAP_PX = 2.0  # gaps in the strokes up to twice this wide do not join two compartments
HOLD_SHARE = 0.25  # a bone holds the compartment between strokes that has this share of its length
MIN_CROSS_PX = 2  # ... or that it crosses for this long, when no bone holds it by share
FOUR = ndimage.generate_binary_structure(2, 1)
THIN_SHARE = 0.95  # an overlap region with this share of its pixels within SIDE_PX + 1 of a contact is one


def stroke_contacts(drawing: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
                    glued: np.ndarray | None = None, parts: tuple | None = None) -> list[np.ndarray]:
    """(H, W) bool contacts of a (H, W, C) float32 drawing: stroke pixels inside the (H, W) bool foreground
    between two compartments of the drawing, with the bodies of two bones that are not neighbours on their two
    sides, in pieces at least MIN_CONTACT_PX long.

    glued: (H, W) bool paper the mesh's foreground closed over (a watercolour hand a few pixels beside the
    skirt, no ink between). It parts bodies as a stroke does.
    parts: drawn_parts' result for this drawing and foreground, when the caller has it already.

    A stroke is a pixel darker than the brightest within STROKE_PX by STROKE_CONTRAST (ink on paper, a dark
    outline on a colour fill, pencil); the compartments are the pieces between strokes (drawn_parts). A
    compartment's pixels go to the nearest of the bones that hold it; one no bone holds (the specks of paper
    inside a crayon outline, an eye) is nobody's body. A stroke with the same compartment on both sides (a
    cheek, a belly button, a fold that ends inside the body) parts nothing. Bones joined through one short
    bone (spine - clavicle - upper arm) meet around it: that bone's body is left out, so the arm stays
    attached at the shoulder.
    """
    stroke, labels, holds = parts if parts is not None else drawn_parts(drawing, foreground, pose, skeleton)
    body = holds.any(axis=0)[labels]  # pixels of held compartments
    if not body.any() or len(skeleton.bones) < 2:
        return []
    fy, fx, bone_dist, ys, xs, owner = _owners(foreground, body, labels, holds, pose, skeleton)
    scale = scale_of(foreground)
    side = int(round(SIDE_PX * scale))
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * side + 1,) * 2)
    near = np.zeros((len(skeleton.bones),) + foreground.shape, bool)
    for bone in np.unique(owner):
        cell = np.zeros(foreground.shape, np.uint8)
        cell[ys[owner == bone], xs[owner == bone]] = 1
        near[bone] = (cv2.dilate(cell, disc) > 0) & stroke
    # two compartments within reach: the largest and the smallest held label seen differ
    held = np.where(body, labels, 0).astype(np.float32)
    most = cv2.dilate(held, disc)
    least = -cv2.dilate(np.where(body, -held, -np.float32(labels.max() + 1)), disc)
    parts_two = stroke & (most > least)
    readings = [(near, parts_two)]
    gap = np.zeros_like(stroke) if glued is None else np.asarray(glued, bool) & ~foreground
    # the outline's soft rim is no gap: keep the paper the mesh holds on both sides
    rim = int(round(RIM_PX * scale))
    gap &= cv2.erode((gap | foreground).astype(np.uint8), np.ones((2 * rim + 1,) * 2, np.uint8)) > 0
    if gap.any():
        nearest = np.full(foreground.shape, -1, np.int64)
        nearest[fy, fx] = np.argmin(bone_dist, axis=0)
        # each reading of the gap's sides is tested alone: bones from two readings on one side are one body
        for owned in (_carried(foreground, body, ys, xs, owner), nearest):
            readings.append((gap_sides(gap, owned, side, len(skeleton.bones)), gap))
    cache: dict = {}  # the bodies' regions, only for bones joined around a short bone
    touching = np.zeros(foreground.shape, bool)
    for near_r, parts_r in readings:
        touching |= _touching(near_r, parts_r, foreground, pose, skeleton, cache)
    labels_t, n = ndimage.label(touching, structure=np.ones((3, 3), bool))
    pieces = []
    for lab in range(1, n + 1):
        piece = labels_t == lab
        if len(longest_path(skeletonize(piece))) >= MIN_CONTACT_PX * scale:
            pieces.append(piece)
    return pieces


def gap_sides(gap: np.ndarray, owned: np.ndarray, side: int, n_bones: int) -> np.ndarray:
    """(B, H, W) bool: the pixels of the (H, W) bool glued paper `gap` that bone b's pixels ((H, W) int64
    `owned`, -1 for none) lie within the gap's half width plus `side` pixels of (its local distance transform):
    paper glued across a strip wider than two sides (a watercolour forearm a few pixels off the waist) still
    parts the bodies along its middle.

    Computed in the box around the gap grown by `side` + 1 pixels: a pixel of the gap lies at most a pixel
    further from the paper or body around the box (inside the box, or the frame's edge) than from the box's
    side, so an owned pixel beyond the box is more than its reach away. The same as over the whole image, at a
    fraction of the cost of one distance transform per bone."""
    out = np.zeros((n_bones,) + gap.shape, bool)
    rows, cols = np.nonzero(gap)
    if len(rows) == 0:
        return out
    grow = side + 1
    box = (slice(max(0, rows.min() - grow), rows.max() + 1 + grow),
           slice(max(0, cols.min() - grow), cols.max() + 1 + grow))
    g, own = gap[box], owned[box]
    limit = ndimage.distance_transform_edt(g) + side
    for bone in np.unique(own[own >= 0]):
        out[(bone, *box)] = g & (ndimage.distance_transform_edt(own != bone) <= limit)
    return out


def _owners(foreground: np.ndarray, body: np.ndarray, labels: np.ndarray, holds: np.ndarray, pose: np.ndarray,
            skeleton: Skeleton) -> tuple[np.ndarray, ...]:
    """Who owns the (H, W) bool body pixels: each goes to the nearest bone among those that hold its compartment
    (drawn_parts' labels and holds). Returns the foreground's pixels (fy, fx), their (B, F) distances to every
    bone, the body's pixels (ys, xs) and their owners (int64 bone indices)."""
    fy, fx = np.nonzero(foreground)  # body pixels are foreground pixels: one distance to each bone serves both
    p = np.stack([fx, fy], axis=1).astype(np.float64)
    bone_dist = np.stack([segment_distance(p, pose[a, :2], pose[b, :2]) for a, b in skeleton.bones])
    in_body = body[fy, fx]
    ys, xs, dist = fy[in_body], fx[in_body], bone_dist[:, in_body]
    dist[~holds[:, labels[ys, xs]]] = np.inf
    return fy, fx, bone_dist, ys, xs, np.argmin(dist, axis=0)


def drawn_bodies(drawing: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
                 parts: tuple | None = None) -> np.ndarray:
    """(H, W) int64: the bone whose body, as drawn, each pixel of the (H, W) bool foreground is (-1 on strokes,
    on compartments no bone holds and off the foreground). A compartment between strokes goes to the bones that
    hold it (drawn_parts, or `parts` when the caller has them), each of its pixels to the nearest of them."""
    _, labels, holds = parts if parts is not None else drawn_parts(drawing, foreground, pose, skeleton)
    body = holds.any(axis=0)[labels]
    owned = np.full(foreground.shape, -1, np.int64)
    if body.any() and len(skeleton.bones):
        _, _, _, ys, xs, owner = _owners(foreground, body, labels, holds, pose, skeleton)
        owned[ys, xs] = owner
    return owned


def stroke_reach(character: np.ndarray) -> int:
    """How far (pixels) a stroke reaches from the body it outlines, for a character whose (H, W) foreground is
    given (scale_of)."""
    return int(round(STROKE_PX * scale_of(character)))


def _touching(near: np.ndarray, parts: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
              cache: dict) -> np.ndarray:
    """(H, W) bool pixels of `parts` ((H, W) bool) that (B, H, W) bool `near` puts beside the bodies of two bones
    that share no joint. Bones joined around a short bone (a waist, a shoulder) touch only outside that
    bone's body and along the longer bone (a limb along the body). cache holds the bodies' regions."""
    adjacent = skeleton.adjacent_bones()
    ends = pose[skeleton.bones, :2].astype(np.float64)  # (B, 2, 2)
    touching = np.zeros(foreground.shape, bool)
    present = [b for b in range(len(near)) if near[b].any()]
    for i in present:
        for j in present:
            if j <= i or adjacent[i, j]:
                continue
            both = near[i] & near[j] & parts
            between = adjacent[i] & adjacent[j]
            if between.any():
                if "thick" not in cache:
                    cache["thick"] = thick_regions(foreground, pose, skeleton)
                both &= ~cache["thick"][between].any(axis=0)
                longer = i if np.linalg.norm(np.diff(ends[i], axis=0)) >= np.linalg.norm(np.diff(ends[j], axis=0)) else j
                both = _along(both, ends[longer])
            touching |= both
    return touching


def _carried(foreground: np.ndarray, body: np.ndarray, ys: np.ndarray, xs: np.ndarray, owner: np.ndarray
             ) -> np.ndarray:
    """(H, W) int64 owner of every foreground pixel (-1 off it): the compartments' owner of the body pixels
    (ys, xs -> owner) carried onto the strokes, each taking its nearest body pixel's (the paint's own edges
    read as strokes: pigment pools there).

    This is one of two readings of glued paper's sides; the other is the nearest bone. Paper glued between
    bodies parts them if either reading alone sees two bones on its sides: the compartments keep a wide
    torso's edge from a forearm beside it, the nearest bone sees through watercolour granulation that
    breaks a hand into specks of strokes."""
    owned = np.full(foreground.shape, -1, np.int64)
    owned[ys, xs] = owner
    _, (iy, ix) = ndimage.distance_transform_edt(~body, return_indices=True)
    return np.where(foreground, owned[iy, ix], -1)


def drawn_parts(drawing: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The drawing's strokes and the compartments between them: (H, W) bool strokes inside the (H, W) bool
    foreground, (H, W) int64 compartment labels (4-connected pieces between strokes, 0 on strokes and off the
    foreground) and (B, n + 1) bool which bones hold which compartment.

    A bone holds a compartment when at least HOLD_SHARE of its length lies in it: a hand joint drawn on the
    torso's outline dips the forearm's tip into the torso, but the torso's pixels near it are still the
    torso's. It also holds one it crosses for MIN_CROSS_PX that no bone holds so (a limb hatched across).
    """
    rgb = np.asarray(drawing, np.float32)[..., :3] if drawing.ndim == 3 else np.asarray(drawing, np.float32)[..., None]
    lum = rgb.mean(axis=-1)
    scale = scale_of(foreground)
    reach = int(round(STROKE_PX * scale))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1,) * 2)
    stroke = foreground & ((cv2.dilate(lum, kernel) - lum) > STROKE_CONTRAST)
    labels, n = _trapped_ball(foreground & ~stroke, TRAP_PX * scale)
    points, owner = bone_samples(pose, skeleton, step=1.0)
    h, w = foreground.shape
    xy = np.round(points).astype(np.int64)
    ok = (xy[:, 0] >= 0) & (xy[:, 0] < w) & (xy[:, 1] >= 0) & (xy[:, 1] < h)
    comp = np.zeros(len(points), np.int64)
    comp[ok] = labels[xy[ok, 1], xy[ok, 0]]
    counts = np.zeros((len(skeleton.bones), n + 1))
    np.add.at(counts, (owner, comp), 1.0)
    strong = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1.0) >= HOLD_SHARE
    # a limb hatched across into short compartments holds each it crosses that no bone holds strongly
    holds = strong | ((counts >= MIN_CROSS_PX) & ~strong.any(axis=0))
    holds[:, 0] = False
    return stroke, labels.astype(np.int64), holds


def scale_of(character: np.ndarray) -> float:
    """How many times a character is larger than the reference drawing (at least 1): the diagonal of the box
    around the nonzero pixels of an (H, W) array (its foreground, its coverage) over REFERENCE_DIAG_PX.

    The character's own size, not its canvas's: the same drawing on a larger page (a canvas grown for the
    motion, a scan with a wide margin) reads its strokes alike. A 256 x 256 keyframe is at most the reference,
    so every such drawing has scale 1."""
    return scale_of_box(*box_size(character))  # no character: (0, 0), scale 1


def scale_of_box(height: float, width: float) -> float:
    """scale_of for a character whose box is (height, width) pixels."""
    return max(1.0, float(np.hypot(height, width)) / REFERENCE_DIAG_PX)


def thin_overlaps(regions: list[np.ndarray], contacts: list[np.ndarray], scale: float = 1.0) -> np.ndarray:
    """(R,) bool: which (H, W) bool overlap regions lie along the (H, W) bool contacts, THIN_SHARE of their
    pixels within SIDE_PX + 1 of one (the band a contact's two sides span); scale: the character's (scale_of)."""
    if not regions or not contacts:
        return np.zeros(len(regions), bool)
    side = int(round(SIDE_PX * scale))
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * side + 3,) * 2)
    band = cv2.dilate(np.any(contacts, axis=0).astype(np.uint8), disc) > 0
    return np.array([(r & band).sum() >= THIN_SHARE * max(int(r.sum()), 1) for r in regions], bool)


def _along(mask: np.ndarray, bone: np.ndarray) -> np.ndarray:
    """The pieces of a (H, W) bool mask that run along a bone ((2, 2) ends, pixels): their principal direction
    within ALONG_DEG of the bone's. Two bodies joined around a short bone meet across the longer one (the
    waistband between a torso and a hip bone); a limb lying along the body touches it lengthwise."""
    d = bone[1] - bone[0]
    if np.linalg.norm(d) < 1e-9:
        return np.zeros_like(mask)
    labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
    keep = np.zeros(n + 1, bool)
    for lab in range(1, n + 1):
        ys, xs = np.nonzero(labels == lab)
        if len(xs) < 3:
            continue
        pts = np.stack([xs, ys], axis=1).astype(np.float64)
        direction = np.linalg.svd(pts - pts.mean(axis=0), full_matrices=False)[2][0]
        keep[lab] = abs(direction @ d) / np.linalg.norm(d) >= np.cos(np.radians(ALONG_DEG))
    return keep[labels]


def _trapped_ball(free: np.ndarray, radius: float) -> tuple[np.ndarray, int]:
    """(H, W) int64 compartments of the (H, W) bool free pixels with gaps in the strokes narrower than 2 radius
    closed (trapped-ball filling: the pieces a ball of that radius cannot leave, each free pixel then joining
    the nearest piece), and their count."""
    core = ndimage.distance_transform_edt(free) > radius
    labels, n = ndimage.label(core, structure=FOUR)
    if n == 0:
        return np.where(free, 0, 0).astype(np.int64), 0
    _, (iy, ix) = ndimage.distance_transform_edt(~core, return_indices=True)
    return np.where(free, labels[iy, ix], 0).astype(np.int64), n


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
