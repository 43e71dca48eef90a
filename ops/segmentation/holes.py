"""Holes in a drawn character: enclosed paper that is background seen through the body (§4.1, foreground).

A region of paper colour enclosed by the character is either part of it (a white shirt, the unfilled
inside of an outlined limb, an eye, an ear) or background seen through a loop of the body (the space
between a hand on the hip and the torso, a curled tail). The skeleton tells them apart:
- a bone crosses the inside of a limb or a shirt, never the background;
  a bone drawn along a thin limb's stroke may pass within a stroke's width of the background beside it
  without crossing it: that grazes only a narrow piece into the body (paper between a waistband's strokes);
- a hole lies between body parts, so the skeleton surrounds it: seen from the hole, the nearby bones
  leave no wide gap of directions; a hand's or a foot's outlined inside, or a compartment of a skirt,
  has bones on one side only;
- the loop around a hole is made of body parts, so its ink lies near bones; an ear's or an antenna
  ball's outline lies far from every bone, so its inside leaks out to the page once only the ink near
  bones counts as wall;
- an eye is a closed shape floating inside the face: its ink does not belong to the character's outer
  outline, so it is no wall, and its inside joins the (bone-crossed) face;
- crayon texture and scribbles leave specks of paper smaller than any hole worth a mesh boundary.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

FOUR = ndimage.generate_binary_structure(2, 1)
EIGHT = np.ones((3, 3), bool)
MAX_GAP_DEG = 120.0  # widest gap of directions, seen from a hole, not covered by a nearby bone
WIDE_HOLE = 2.0  # a piece holding a disc this many times min_radius wide is no sliver of a body's inside


def widest_gap(centre: np.ndarray, points: np.ndarray) -> float:
    """Widest angular gap, degrees, between (n, 2) points seen from a (2,) centre (360 with fewer than 2)."""
    if len(points) < 2:
        return 360.0
    ang = np.sort(np.degrees(np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0])))
    gaps = np.diff(np.concatenate([ang, ang[:1] + 360.0]))
    return float(gaps.max())


def surrounded(piece: np.ndarray, bone_points: np.ndarray, bone_reach: np.ndarray) -> bool:
    """Whether the bone samples within reach of a (H, W) bool piece surround it (widest gap <= MAX_GAP_DEG).

    bone_points: (n, 2) float64 samples along the bones, pixels (x, y); bone_reach: (n,) float64 pixels.
    """
    rows, cols = np.nonzero(piece)
    pixels = np.stack([cols, rows], axis=1).astype(np.float64)
    dist, _ = cKDTree(pixels).query(bone_points)
    near = bone_points[dist <= bone_reach]
    # seen from the piece's deepest point, its pole of inaccessibility
    r0, c0 = rows.min(), cols.min()
    box = np.pad(piece[r0 : rows.max() + 1, c0 : cols.max() + 1], 1).astype(np.uint8)
    dt = cv2.distanceTransform(box, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    r, c = np.unravel_index(int(np.argmax(dt)), dt.shape)
    return widest_gap(np.array([c + c0 - 1, r + r0 - 1], np.float64), near) <= MAX_GAP_DEG


def find_holes(
    silhouette: np.ndarray, ink: np.ndarray, crossed: np.ndarray, near_bones: np.ndarray,
    bone_points: np.ndarray, bone_reach: np.ndarray, min_radius: float, grazed: np.ndarray | None = None,
) -> np.ndarray:
    """(H, W) bool holes inside a (H, W) bool filled silhouette.

    ink: (H, W) bool ink (gaps closed); crossed: (H, W) bool pixels on a bone's line (thin); grazed: (H, W) bool
    pixels a bone passes within a stroke's width of (a piece narrower than WIDE_HOLE times min_radius that a bone
    grazes is the inside of that bone's body: paper between a waistband's two strokes; a wider one is background
    seen through a loop, which a forearm drawn thin beside the face passes at its rim); near_bones: (H, W) bool
    pixels close enough to a bone for its ink to belong to that body part; bone_points (n, 2) float64 and
    bone_reach (n,) float64: samples along the bones and how far each one's body reaches, pixels;
    min_radius: pixels, the radius of the largest disc a hole must hold.
    """
    exterior = ~silhouette
    ink_labels, _ = ndimage.label(ink, structure=EIGHT)
    # ink that touches the page outside is the character's outline network; floating details are no wall
    touching = cv2.dilate(exterior.astype(np.uint8), EIGHT.astype(np.uint8)) > 0
    outline_ids = np.unique(ink_labels[touching & ink])
    outline = np.isin(ink_labels, outline_ids[outline_ids > 0])
    walls = ink & outline & near_bones

    free_labels, n = ndimage.label(~walls, structure=FOUR)
    if n == 0:
        return np.zeros_like(silhouette)
    open_ids = np.unique(free_labels[exterior | crossed])
    is_hole = np.ones(n + 1, bool)
    is_hole[0] = False
    is_hole[open_ids] = False
    candidates = is_hole[free_labels] & silhouette & ~ink

    pieces, m = ndimage.label(candidates, structure=FOUR)
    if m == 0:
        return candidates
    depth = cv2.distanceTransform(candidates.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    inscribed = np.zeros(m + 1, np.float32)
    np.maximum.at(inscribed, pieces[candidates], depth[candidates])
    if grazed is not None:  # a narrow piece a bone grazes is that body's inside
        touched = np.zeros(m + 1, bool)
        touched[np.unique(pieces[grazed & candidates])] = True
        inscribed[touched & (inscribed < WIDE_HOLE * min_radius)] = 0.0
    keep = np.zeros(m + 1, bool)
    for i in np.nonzero(inscribed >= min_radius)[0]:
        keep[i] = surrounded(pieces == i, bone_points, bone_reach)
    return keep[pieces]
