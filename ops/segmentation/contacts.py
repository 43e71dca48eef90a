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

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from skimage.morphology import skeletonize

from ops.geometry.mesh import project_to_polyline

from ops.segmentation.bones import bone_radii, segment_distance
from ops.types import Skeleton

CONTACT_BAND_PX = 2  # the band reaches this far into each body from the border between their cells
MIN_CONTACT_PX = 8  # shorter contacts (band area / band width) are a corner touching, not a shared stroke
SLIT_STEP_PX = 3  # spacing of a slit's polyline vertices along the contact
REACH_OUTLINE_PX = 6.0  # a slit's end this close to the outline is carried on to it


def body_cells(foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(B, H, W) bool: every foreground pixel goes to the bone whose body surface is nearest (distance to the
    segment less the bone's radius), so two cells meet where the drawn bodies meet, not halfway between the
    bones (a thin arm along a wide torso)."""
    ys, xs = np.nonzero(foreground)
    p = np.stack([xs, ys], axis=1).astype(np.float64)
    radii = bone_radii(foreground, pose, skeleton)
    gap = np.stack([segment_distance(p, pose[a, :2], pose[b, :2]) - r for (a, b), r in zip(skeleton.bones, radii)])
    owner = np.argmin(gap, axis=0)
    cells = np.zeros((len(radii),) + foreground.shape, bool)
    cells[owner, ys, xs] = True
    return cells


def contact_bands(foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton, thick: np.ndarray,
                  depth: np.ndarray) -> list[tuple[int, int, np.ndarray]]:
    """(front bone, back bone, (H, W) bool band) of every contact; thick: (B, H, W) bool bodies (thick_regions),
    depth: (B,) bone depths (larger = farther). Pairs of equal depth have no front and are left out."""
    cells = body_cells(foreground, pose, skeleton)
    near = [ndimage.binary_dilation(c, iterations=CONTACT_BAND_PX) if c.any() else c for c in cells]
    adjacent = skeleton.adjacent_bones()
    out = []
    for i in range(len(cells)):
        for j in range(i + 1, len(cells)):
            if adjacent[i, j] or np.isclose(depth[i], depth[j]):
                continue
            band = ((cells[i] & near[j]) | (cells[j] & near[i])) & foreground
            between = adjacent[i] & adjacent[j]
            if between.any():
                band &= ~thick[between].any(axis=0)
            if not band.any():
                continue
            front, back = (i, j) if depth[i] < depth[j] else (j, i)
            out.append((front, back, band))
    return out


def band_ends(band: np.ndarray) -> np.ndarray:
    """(2, 2) float64 (x, y) of the two pixels of a (H, W) bool band farthest apart (its ends, for a strip)."""
    ys, xs = np.nonzero(band)
    p = np.stack([xs, ys], axis=1).astype(np.float64)
    a = p[np.argmax(((p - p.mean(axis=0)) ** 2).sum(axis=1))]
    b = p[np.argmax(((p - a) ** 2).sum(axis=1))]
    return np.stack([a, b])


def contact_pieces(bands: list[tuple[int, int, np.ndarray]]) -> list[np.ndarray]:
    """(H, W) bool pieces of the bands' union at least MIN_CONTACT_PX long. The union first: an arm along the
    torso touches it with the upper arm and the forearm, one stroke to be cut whole."""
    if not bands:
        return []
    labels, n = ndimage.label(np.any([band for _, _, band in bands], axis=0), structure=np.ones((3, 3), bool))
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    width = 2 * CONTACT_BAND_PX + 1
    return [labels == lab for lab in range(1, n + 1) if sizes[lab] >= MIN_CONTACT_PX * width]


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
        piece = piece & ~ndimage.binary_dilation(avoid, iterations=CONTACT_BAND_PX + 1)
    labels, n = ndimage.label(piece, structure=np.ones((3, 3), bool))
    if n == 0:
        return None
    sizes = np.bincount(labels.ravel())[1:]
    piece = labels == 1 + int(np.argmax(sizes))
    if sizes.max() < MIN_CONTACT_PX * (2 * CONTACT_BAND_PX + 1):
        return None
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
