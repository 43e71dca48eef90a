"""Slits: the open polylines the template mesh is cut along, one per contact (ops.segmentation.contacts).

A slit follows the middle of a contact's stroke, keeps clear of the occlusion regions (their boundaries are
mesh constraints it must not cross), and an end near the outline is carried on to it, so the cut opens a
flap there rather than a slot.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from skimage.morphology import skeletonize

from ops.geometry.mesh import project_to_polyline
from ops.segmentation.contacts import MIN_CONTACT_PX, longest_path

AVOID_PX = 3  # a slit keeps this far from the occlusion regions' boundaries (mesh constraints)
SLIT_STEP_PX = 3  # spacing of a slit's polyline vertices along the contact
REACH_OUTLINE_PX = 10.0  # a slit's end this close to the outline is carried on to it (across the notch where two bodies part)


def slit_of(piece: np.ndarray, avoid: np.ndarray, domain: list[np.ndarray]) -> np.ndarray | None:
    """(k, 2) float64 open polyline along a contact piece ((H, W) bool), AVOID_PX clear of `avoid` (the
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
    path = longest_path(skeletonize(piece))
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
