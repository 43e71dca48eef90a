"""Where a motion takes a drawn character, and the canvas that holds it.

A one-drawing shot driven by a clip (an AnimatedDrawings character and a BVH) keeps the drawing's own canvas, and
AnimatedDrawings' textures are cropped close to the character: a jump or raised arms leave the frame, and every
frame is cut there. The character's outline, carried rigidly with the bone each outline point is nearest to,
says how far each pose reaches; the canvas grows by that much (plus a margin) on the sides it is short of.
"""
from __future__ import annotations

import cv2
import numpy as np

from ops.segmentation.bones import moved_with_bones, segment_distance
from ops.types import Skeleton

MARGIN_PX = 8  # room kept between the carried outline and the canvas edge
OUTLINE_STEP_PX = 2  # spacing of the outline points carried with the bones


def outline_points(mask: np.ndarray, step: int = OUTLINE_STEP_PX) -> np.ndarray:
    """(n, 2) float64 x, y pixels along the outer outlines of an (H, W) bool mask, about `step` px apart."""
    contours, _ = cv2.findContours(np.asarray(mask, np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    pts = [c.reshape(-1, 2)[::step] for c in contours if len(c)]
    return np.concatenate(pts).astype(np.float64) if pts else np.zeros((0, 2))


def carried_with_bones(points: np.ndarray, pose: np.ndarray, poses: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(F, n, 2) pixels: (n, 2) points of a drawing at its (J, >=2) pose, each carried rigidly with its nearest
    bone to each of the (F, J, >=2) poses: it keeps its fraction along the bone and its offset across it, turned
    as the bone turns (a bone that changes length stretches the fraction, not the offset)."""
    ends = pose[:, :2].astype(np.float64)[skeleton.bones]  # (B, 2, 2)
    owner = np.argmin(np.stack([segment_distance(points, a, b) for a, b in ends]), axis=0)  # (n,)
    there = np.asarray(poses, np.float64)[:, :, :2][:, skeleton.bones]  # (F, B, 2, 2)
    return moved_with_bones(points, ends[owner], there[:, owner])


def padding_for(points: np.ndarray, size: tuple[int, int], margin: float = MARGIN_PX,
                rest: np.ndarray | None = None) -> tuple[int, int, int, int]:
    """(left, top, right, bottom) pixels to add to a canvas of (H, W) so that every (..., 2) point lies at
    least `margin` px inside it; zeros where it already does.

    rest: the (n, 2) points where the drawing itself has them. A side the drawing already comes nearer than
    `margin` to keeps only the room it has there: a texture cropped at the feet is not padded below them for
    a motion that does not move them lower."""
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    if not len(pts):
        return 0, 0, 0, 0
    h, w = size
    room = np.full(4, float(margin))  # left, top, right, bottom
    if rest is not None and len(rest):
        own = np.asarray(rest, np.float64).reshape(-1, 2)
        lo, hi = own.min(axis=0), own.max(axis=0)
        room = np.minimum(room, np.maximum([lo[0], lo[1], w - 1 - hi[0], h - 1 - hi[1]], 0.0))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    need = [room[0] - lo[0], room[1] - lo[1], hi[0] + room[2] - (w - 1), hi[1] + room[3] - (h - 1)]
    return tuple(int(np.ceil(max(0.0, v - 1e-9))) for v in need)


def pad_drawing(image: np.ndarray, pad: tuple[int, int, int, int], outside: np.ndarray) -> np.ndarray:
    """(H + top + bottom, W + left + right, C) float32: an (H, W, C) [0, 1] drawing on a larger canvas. The new
    border is the paper: clear where the drawing is a cut-out (transparent at its edge), else the median colour of
    the drawing's pixels where (H, W) bool `outside` (the paper around the character) holds. Not the edge's
    pixels repeated: a drawing cropped at the feet would smear them outward."""
    left, top, right, bottom = pad
    img = np.asarray(image, np.float32)
    if img.ndim == 2:
        img = img[..., None]
    out = np.empty((img.shape[0] + top + bottom, img.shape[1] + left + right, img.shape[2]), np.float32)
    channels = img.shape[2]
    has_alpha = channels in (2, 4)
    colour = img.shape[2] - int(has_alpha)
    edge = np.concatenate([img[0], img[-1], img[:, 0], img[:, -1]])
    if has_alpha and float(np.median(edge[:, -1])) < 0.5:  # a cut-out: the paper is transparent
        out[:] = 0.0
        out[..., :colour] = 1.0
    else:
        paper = img[np.asarray(outside, bool)] if np.any(outside) else edge
        out[:] = np.median(paper, axis=0)
        if has_alpha:
            out[..., -1] = 1.0
    out[top:top + img.shape[0], left:left + img.shape[1]] = img
    return out if image.ndim == 3 else out[..., 0]
