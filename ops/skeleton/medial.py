"""The medial axis of a silhouette as a graph: where limbs run, where they end, how far apart along the body.

scikit-image thins the silhouette to its one-pixel skeleton; its pixels become graph nodes joined to their
8-neighbours (edge length 1 or sqrt 2). Spurs that the outline's bumps grow (a branch shorter than the
body is wide where it leaves) are pruned, and pieces of the silhouette drawn apart (a head floating above
its body) are joined by the shortest bridge between them, made dearer per pixel than the axis itself, so
that paths prefer to stay on the body. Shortest paths on it are scipy.sparse.csgraph's Dijkstra.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from skimage.morphology import skeletonize

SPUR_SHARE = 0.5  # a branch sticking out past the fork's inscribed circle by less than this share of its radius
MIN_SPUR_PX = 3.0  # ... or by less than this many pixels is a bump of the outline, not a limb
BRIDGE_COST = 3.0  # a pixel across paper between separate pieces costs this many pixels of axis
NEIGHBOURS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


@dataclass
class MedialGraph:
    """A silhouette's pruned skeleton: nodes, their body radius, edges, and which nodes are limb ends."""

    points: np.ndarray  # (N, 2) float64 x, y pixels of the skeleton's pixels
    radius: np.ndarray  # (N,) float64 distance to the silhouette's edge, pixels
    graph: csr_matrix  # (N, N) edge lengths, pixels (bridges weighted by BRIDGE_COST)
    ends: np.ndarray  # (E,) int64 nodes of degree 1: where a limb, a head or a tail ends
    branch: np.ndarray  # (E,) float64 length of each end's branch up to its first fork, pixels

    def distances(self, sources: np.ndarray) -> np.ndarray:
        """(len(sources), N) float64 shortest-path length along the axis from each source node, pixels."""
        return dijkstra(self.graph, directed=False, indices=np.asarray(sources, np.int64))


def _pixel_graph(skel: np.ndarray) -> tuple[np.ndarray, csr_matrix]:
    """(N, 2) int (row, col) of skeleton pixels and their 8-neighbour graph."""
    rc = np.argwhere(skel)
    index = -np.ones(skel.shape, np.int64)
    index[rc[:, 0], rc[:, 1]] = np.arange(len(rc))
    h, w = skel.shape
    rows, cols, vals = [], [], []
    for dr, dc in NEIGHBOURS:
        r2, c2 = rc[:, 0] + dr, rc[:, 1] + dc
        ok = (r2 >= 0) & (r2 < h) & (c2 >= 0) & (c2 < w)
        j = np.full(len(rc), -1)
        j[ok] = index[r2[ok], c2[ok]]
        m = j >= 0
        rows.append(np.nonzero(m)[0])
        cols.append(j[m])
        vals.append(np.full(int(m.sum()), np.hypot(dr, dc)))
    n = len(rc)
    g = coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()
    return rc, g


def _prune(skel: np.ndarray, dt: np.ndarray, passes: int = 3) -> np.ndarray:
    """The skeleton without spurs: end branches whose tip (axis end plus its radius) reaches less than
    SPUR_SHARE x the fork's radius past the fork's inscribed circle."""
    skel = skel.copy()
    for _ in range(passes):
        rc, g = _pixel_graph(skel)
        deg = np.diff(g.indptr)
        removed = False
        for e in np.nonzero(deg == 1)[0]:
            path, prev, cur, length = [e], -1, e, 0.0
            while True:
                nb = [int(v) for v in g.indices[g.indptr[cur]:g.indptr[cur + 1]] if v != prev]
                if len(nb) != 1 or deg[cur] > 2 and cur != e:
                    break
                nxt = nb[0]
                length += float(np.hypot(*(rc[nxt] - rc[cur])))
                prev, cur = cur, nxt
                if deg[cur] > 2:
                    break
                path.append(cur)
            if deg[cur] <= 2:  # reached another end: an isolated segment, keep it
                continue
            fork_r = dt[rc[cur, 0], rc[cur, 1]]
            protrusion = length + dt[rc[e, 0], rc[e, 1]] - fork_r  # how far the branch's tip reaches past the fork
            if protrusion < max(MIN_SPUR_PX, SPUR_SHARE * fork_r):
                skel[rc[path, 0], rc[path, 1]] = False
                removed = True
        if not removed:
            break
        skel = skeletonize(skel)  # re-thin where removing a spur left a corner two pixels thick
    return skel


def _bridges(points: np.ndarray, g: csr_matrix) -> csr_matrix:
    """g plus the shortest bridge (BRIDGE_COST per pixel) joining every component to the rest, greedily."""
    n_comp, label = connected_components(g, directed=False)
    if n_comp <= 1:
        return g
    extra_r, extra_c, extra_v = [], [], []
    joined = {int(label[0])}
    while len(joined) < n_comp:
        inside = np.isin(label, list(joined))
        a, b = np.nonzero(inside)[0], np.nonzero(~inside)[0]
        # nearest pair between the joined set and the rest (subsampled when large: the bridge is approximate)
        a_s, b_s = a[:: max(1, len(a) // 800)], b[:: max(1, len(b) // 800)]
        d = np.linalg.norm(points[a_s, None] - points[None, b_s], axis=2)
        i, j = np.unravel_index(int(np.argmin(d)), d.shape)
        extra_r.append(a_s[i])
        extra_c.append(b_s[j])
        extra_v.append(BRIDGE_COST * max(d[i, j], 1.0))
        joined.add(int(label[b_s[j]]))
    n = g.shape[0]
    bridge = coo_matrix((extra_v, (extra_r, extra_c)), shape=(n, n)).tocsr()
    return (g + bridge + bridge.T).tocsr()


def medial_graph(mask: np.ndarray) -> MedialGraph:
    """Medial graph of a (H, W) bool silhouette."""
    mask = np.asarray(mask, bool)
    dt = ndimage.distance_transform_edt(mask)
    skel = _prune(skeletonize(mask), dt)
    if not skel.any():  # a sliver thinner than the thinning can keep
        r, c = np.unravel_index(int(np.argmax(dt)), dt.shape)
        skel[r, c] = True
    rc, g = _pixel_graph(skel)
    points = rc[:, ::-1].astype(np.float64)
    g = _bridges(points, g)
    plain = _pixel_graph(skel)[1]
    deg = np.diff(plain.indptr)
    ends = np.nonzero(deg <= 1)[0]
    branch = np.array([_branch_length(plain, deg, int(e)) for e in ends])
    return MedialGraph(points=points, radius=dt[rc[:, 0], rc[:, 1]], graph=g, ends=ends.astype(np.int64),
                       branch=branch)


def _branch_length(g: csr_matrix, deg: np.ndarray, end: int) -> float:
    """Length, pixels, from an end node along its branch to the first fork (or the branch's other end)."""
    prev, cur, length = -1, end, 0.0
    while True:
        nb = [int(v) for v in g.indices[g.indptr[cur]:g.indptr[cur + 1]] if v != prev]
        if not nb or (deg[cur] > 2 and cur != end):
            return length
        k = g.indptr[cur] + list(g.indices[g.indptr[cur]:g.indptr[cur + 1]]).index(nb[0])
        length += float(g.data[k])
        prev, cur = cur, nb[0]
