"""The area a keyframe's template meshes (§4.2): every pixel the character covers, holes kept open.

The domain is the support of the character's coverage (alpha > 0, so the
anti-aliased fringe of an outline is inside the mesh and keeps its drawn
width), dilated by a pixel or two so that the renderer's supersamples of
fringe pixels fall inside it, as closed polylines: the outline of every
component and of every hole (paper enclosed by the body, which the mask
already leaves out). Each hole gets a point inside it for the mesher.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from ops.geometry.polygon import points_in_polygon, polygon_area, rasterize

DILATE_PX = 2  # margin of the domain beyond the last pixel with coverage
DP_EPS_PX = 1.0  # Douglas-Peucker tolerance of the domain outlines (less than the margin)
MIN_LOOP_AREA_PX = 4.0  # components or holes smaller than this are not meshed


def mesh_domain(
    foreground: np.ndarray, coverage: np.ndarray, holes: np.ndarray | None = None,
) -> tuple[list[np.ndarray], np.ndarray]:
    """(H, W) bool foreground, float32 coverage and optional (H, W) bool holes -> (closed polylines (n_i, 2)
    float64 pixels, (h, 2) hole points).

    The margin grows at most a pixel into a hole: a hole between an arm and the body is often only a few
    pixels wide once its fringe belongs to the character, and the full margin would glue the arm to the body.
    Outer outlines have positive shoelace area, hole outlines negative (image coordinates, y down).
    """
    support = np.asarray(foreground, bool) | (np.asarray(coverage) > 0)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * DILATE_PX + 1,) * 2)
    pad = DILATE_PX + 1
    domain = cv2.dilate(np.pad(support.astype(np.uint8), pad), kernel)
    if holes is not None:  # a pixel of margin into a hole, so the outline's last pixels are wholly inside
        near = cv2.dilate(support.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        domain[np.pad(np.asarray(holes, bool) & ~near, pad)] = 0
    contours, hierarchy = cv2.findContours(domain, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    loops, holes = [], []
    for c, (_, _, _, parent) in zip(contours, hierarchy.reshape(-1, 4) if hierarchy is not None else []):
        if abs(cv2.contourArea(c)) < MIN_LOOP_AREA_PX:
            continue
        P = cv2.approxPolyDP(c, DP_EPS_PX, True).reshape(-1, 2).astype(np.float64) - pad
        if len(P) < 3:
            continue
        is_hole = parent >= 0
        seed = _point_inside(c, domain.shape, pad) if is_hole else None
        if is_hole and not points_in_polygon(seed[None], P)[0]:
            continue  # a sliver of a hole that the simplified outline no longer encloses: its seed would eat the mesh
        area = 0.5 * float(np.dot(P[:, 0], np.roll(P[:, 1], -1)) - np.dot(np.roll(P[:, 0], -1), P[:, 1]))
        if (area < 0) != is_hole:
            P = P[::-1].copy()
        loops.append(P)
        if is_hole:
            holes.append(seed)
    return loops, np.asarray(holes, np.float64).reshape(-1, 2)


def closed_holes(foreground: np.ndarray, coverage: np.ndarray, holes: np.ndarray) -> np.ndarray:
    """(H, W) bool pixels of the (H, W) bool holes that the mesh closes over: a sliver of paper between a
    watercolour forearm and the waist too thin to stay open once the domain's margin is added, or too small
    to be meshed. The mesh holds them as it holds the foreground."""
    holes = np.asarray(holes, bool)
    if not holes.any():
        return holes.copy()
    loops, _ = mesh_domain(foreground, coverage, holes)
    open_ = np.zeros(holes.shape, bool)
    for P in loops:
        if polygon_area(P) < 0:
            open_ |= rasterize(P, holes.shape)
    return holes & ~open_


def _point_inside(contour: np.ndarray, shape: tuple[int, int], pad: int) -> np.ndarray:
    """(2,) a pixel centre deep inside the region a hole contour encloses (farthest from its outline)."""
    inside = np.zeros(shape, np.uint8)
    cv2.drawContours(inside, [contour], 0, 1, thickness=-1)
    cv2.drawContours(inside, [contour], 0, 0, thickness=1)  # the contour pixels belong to the domain
    dist = ndimage.distance_transform_edt(inside)
    y, x = np.unravel_index(int(np.argmax(dist)), dist.shape)
    return np.array([x - pad, y - pad], np.float64)
