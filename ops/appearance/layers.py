"""The layers that overlap at rest: each occlusion region's front-sheet faces and its pocket (§5.1).

Their order is decided once per layer, from the bounded biharmonic depth averaged over the layer, both when
texturing (which layer shows the drawing at the keyframe) and when rendering (which layer is drawn in
front): per-face depths would let single faces of the hidden layer poke through the shown one.
"""
from __future__ import annotations

import numpy as np

from ops.types import Template


def region_of_front_faces(template: Template) -> np.ndarray:
    """(m,) int64 occlusion region of each front-sheet face (-1 outside every region or not on the front sheet).

    A pocket (layer r + 1) is a copy of region r's front-sheet faces at the same rest positions, so a front-sheet
    face belongs to region r when a layer r + 1 face has its rest centroid. Where regions are nested (three
    local layers) the face belongs to the region stacked first, whose pocket was made first.
    """
    layer = template.face_layer
    pocket = layer > 0
    out = np.full(len(layer), -1, np.int64)
    if not pocket.any():
        return out
    stack = rest_stacks(template)
    region_of = np.full(int(stack.max()) + 1, -1, np.int64)
    last_first = slice(None, None, -1)  # pockets are appended front to back: written last, the first one wins
    region_of[stack[pocket][last_first]] = (layer[pocket] - 1)[last_first]
    out[~pocket] = region_of[stack[~pocket]]
    return out


def layer_groups(template: Template) -> np.ndarray:
    """(m,) int64 group of each face: 2r for region r's front-sheet faces, 2r + 1 for its pocket, -1 elsewhere."""
    groups = 2 * region_of_front_faces(template)
    groups[groups < 0] = -1
    pocket = template.face_layer > 0
    groups[pocket] = 2 * (template.face_layer[pocket] - 1) + 1
    return groups


def layer_depth(face_depth: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """(m,) depth with each group's faces given the group's mean depth; faces outside every group keep theirs."""
    out = np.array(face_depth, np.float64, copy=True)
    inside = groups >= 0
    if inside.any():
        sums = np.bincount(groups[inside], weights=out[inside])
        counts = np.bincount(groups[inside])
        out[inside] = sums[groups[inside]] / counts[groups[inside]]
    return out


def rest_stacks(template: Template) -> np.ndarray:
    """(m,) int64 label of each face's rest position: faces with one label lie on each other at rest (a front-sheet
    face and its copies in the pockets), every other face has a label of its own."""
    key = np.round(template.rest[template.faces].mean(axis=1) * 1e4).astype(np.int64)
    return np.unique(key, axis=0, return_inverse=True)[1].ravel().astype(np.int64)
