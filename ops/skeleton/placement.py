"""A skeleton template placed on a drawing: every joint on the silhouette's medial axis, limbs along it.

A pictorial-structures fit (Felzenszwalb & Huttenlocher 2005) on the template's tree, solved exactly by
dynamic programming over candidate spots, the nodes of the silhouette's medial graph (ops.skeleton.medial):

- each joint prefers its template position mapped into the silhouette's bounding box (a weak prior);
- each bone prefers to run along the axis (the path between its ends along the axis about as long as the
  straight segment: a bone cutting across paper or across a bend is expensive), to have roughly the length
  and the direction the template gives it (weak: drawings have their own proportions and poses);
- each end of the tree (head, hands, feet, a tail tip) prefers an end of the axis.

Ends of the tree are made distinct: min-marginals of the tree (two passes) score every (tree end, axis end)
pair, the Hungarian method (scipy's linear_sum_assignment) picks a one-to-one assignment, and the tree is
solved again with those ends fixed. A joint's confidence is how much worse the best fit gets when that joint
is moved a tenth of the character's size away from its spot (its min-marginal gap), mapped to [0, 1].

The fit runs on the silhouette scaled to WORK_SIDE pixels; positions are returned in the drawing's pixels.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.sparse.csgraph import dijkstra

from ops.skeleton.medial import MedialGraph, medial_graph
from ops.skeleton.templates import SkeletonTemplate

LENGTH_EPS = 0.02  # character sizes added to both lengths of the ratio, so a short bone's ratio stays finite
END_REACH = 0.1  # character sizes: a tree end within this of an axis end sits on that end
LEAF_STRETCH = 0.5  # a tree end may move back along this share of its bone's axis path ...
BLOB_RATIO, BLOB_PX = 1.2, 2.0  # ... to where the body is this much (and this many work pixels) wider than at
#                                the axis end: a head, a fist, a foot; a pencil line's noise is no blob
WORK_SIDE = 192  # the silhouette's long side during the fit, pixels: enough for limbs a few pixels wide
MAX_CANDIDATES = 900  # medial nodes kept as candidate spots (thinned evenly beyond that)


@dataclass(frozen=True)
class Weights:
    """The fit's energy weights; tuned on generated train-seed drawings of the ink, flat colour and scan styles."""

    prior: float = 1.0  # squared distance to the template spot, in character sizes
    along: float = 6.0  # detour of the axis path over the straight bone, character sizes
    length: float = 1.0  # squared log ratio of the bone length to the template's (softened by LENGTH_EPS)
    direction: float = 0.6  # 1 - cos of the angle to the template's bone direction
    zero: float = 30.0  # a zero-length template bone (root and hip on one spot): its length, character sizes
    off_end: float = 1.5  # a tree end that sits on no axis end, per character size from the nearest axis end
    claim: float = 2.0  # reward for a tree end on an axis end, per character size of that end's branch: a long
    #                     limb sticking out (a raised arm) must be explained, a pigtail or a skirt's corner need not
    gap_scale: float = 0.25  # min-marginal gap that reads as confidence 1 - 1/e


WEIGHTS = Weights()


@dataclass
class Placement:
    """A template placed on a drawing."""

    joints: tuple[str, ...]
    parents: tuple[int, ...]
    positions: np.ndarray  # (J, 2) float64 x, y pixels of the drawing
    confidence: np.ndarray  # (J,) float64 in [0, 1]
    box: tuple[float, float, float, float]  # the silhouette's x0, y0, x1, y1 pixels
    warnings: list[str] = field(default_factory=list)


def _children(parents: tuple[int, ...]) -> list[list[int]]:
    kids: list[list[int]] = [[] for _ in parents]
    for j, p in enumerate(parents):
        if p >= 0:
            kids[p].append(j)
    return kids


def _post_order(parents: tuple[int, ...]) -> list[int]:
    """Joints with every child before its parent."""
    kids = _children(parents)
    root = parents.index(-1)
    order, stack = [], [(root, False)]
    while stack:
        j, done = stack.pop()
        if done:
            order.append(j)
        else:
            stack.append((j, True))
            stack.extend((c, False) for c in kids[j])
    return order


class _Tree:
    """The energy on N candidate spots, its min-sum messages and min-marginals."""

    def __init__(self, template: SkeletonTemplate, spots: np.ndarray, geodesic: np.ndarray, ends: np.ndarray,
                 end_distance: np.ndarray, box: np.ndarray, w: Weights):
        self.parents = tuple(int(p) for p in template.parents)
        self.kids = _children(self.parents)
        x0, y0, x1, y1 = box
        size = max(x1 - x0, y1 - y0, 1.0)
        self.size = size
        expected = np.c_[x0 + template.positions[:, 0] * (x1 - x0), y0 + template.positions[:, 1] * (y1 - y0)]
        self.expected = expected
        J, N = len(self.parents), len(spots)
        leaves = [j for j in range(J) if not self.kids[j]]
        self.leaves = leaves
        self.unary = w.prior * (np.linalg.norm(spots[None] - expected[:, None], axis=2) / size) ** 2
        for j in leaves:
            self.unary[j] += w.off_end * end_distance / size
        diff = spots[None, :, :] - spots[:, None, :]  # (N, N, 2): from parent spot (row) to child spot (col)
        dist = np.linalg.norm(diff, axis=2)
        detour = np.maximum(geodesic - dist, 0.0) / size
        self.pair: dict[int, np.ndarray] = {}
        for c in range(J):
            p = self.parents[c]
            if p < 0:
                continue
            e = expected[c] - expected[p]
            le = float(np.linalg.norm(e))
            if le < 0.01 * size:
                self.pair[c] = w.zero * dist / size
                continue
            cos = (diff @ (e / le)) / np.maximum(dist, 1e-9)
            cos = np.where(dist > 1e-9, cos, 1.0)
            eps = LENGTH_EPS * size
            self.pair[c] = (w.along * detour + w.length * np.log((dist + eps) / (le + eps)) ** 2
                            + w.direction * (1.0 - cos) * min(1.0, le / (0.1 * size)))
        self.order = _post_order(self.parents)
        self.root = self.parents.index(-1)
        self.N = N

    def solve(self, unary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(J,) best spot per joint and (J, N) min-marginals (energy of the best fit with joint j at spot n)."""
        J = len(self.parents)
        up = np.zeros((J, self.N))  # message from joint j to its parent, indexed by the parent's spot
        arg = np.zeros((J, self.N), np.int64)
        inner = unary.copy()  # unary plus messages from children
        for j in self.order:
            for c in self.kids[j]:
                inner[j] += up[c]
            p = self.parents[j]
            if p >= 0:
                total = self.pair[j] + inner[j][None, :]
                arg[j] = np.argmin(total, axis=1)
                up[j] = total[np.arange(self.N), arg[j]]
        best = np.zeros(J, np.int64)
        best[self.root] = int(np.argmin(inner[self.root]))
        marg = np.zeros((J, self.N))
        marg[self.root] = inner[self.root]
        for j in reversed(self.order):  # parents before children
            for c in self.kids[j]:
                best[c] = arg[c][best[j]]
                outside = marg[j] - up[c]  # everything but c's subtree, per parent spot
                marg[c] = inner[c] + np.min(self.pair[c] + outside[:, None], axis=0)
        return best, marg


def _thin(graph: MedialGraph) -> np.ndarray:
    """Candidate node indices: every medial node, thinned evenly to MAX_CANDIDATES, ends always kept."""
    n = len(graph.points)
    keep = np.arange(n)
    if n > MAX_CANDIDATES:
        keep = np.unique(np.concatenate([np.linspace(0, n - 1, MAX_CANDIDATES).astype(np.int64), graph.ends]))
    return keep


def _leaf_centres(graph: MedialGraph, cand: np.ndarray, best: np.ndarray, tree: _Tree) -> np.ndarray:
    """(J, 2) spots with every tree end moved back from the axis end to the widest point of its last stretch.

    An axis end lies about one body radius short of the outline's tip; annotators put a head, a fist or a
    foot joint at the middle of that blob, where the body is widest. A limb of even width keeps its end.
    """
    pos = graph.points[cand[best]].copy()
    for j in tree.leaves:
        p = tree.parents[j]
        src, dst = int(cand[best[p]]), int(cand[best[j]])
        dist, pred = dijkstra(graph.graph, directed=False, indices=dst, return_predecessors=True)
        if not np.isfinite(dist[src]) or src == dst:
            continue
        path, k = [], src
        while k != dst and k >= 0:
            path.append(k)
            k = int(pred[k])
        path.append(dst)
        path = np.array(path[::-1])  # from the end back towards the parent
        stretch = path[dist[path] <= LEAF_STRETCH * dist[src]]
        widest = stretch[int(np.argmax(graph.radius[stretch]))]
        if graph.radius[widest] >= max(BLOB_RATIO * graph.radius[dst], graph.radius[dst] + BLOB_PX):
            pos[j] = graph.points[widest]
    return pos


def place_template(mask: np.ndarray, template: SkeletonTemplate, weights: Weights = WEIGHTS) -> Placement:
    """Place `template` on a (H, W) bool silhouette: positions in its pixels, per-joint confidence."""
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        raise ValueError("empty silhouette")
    x0, x1, y0, y1 = float(xs.min()), float(xs.max()), float(ys.min()), float(ys.max())
    scale = WORK_SIDE / max(x1 - x0 + 1, y1 - y0 + 1)
    pad = 4
    crop = mask[int(y0):int(y1) + 1, int(x0):int(x1) + 1].astype(np.uint8)
    small = cv2.resize(crop, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) > 0
    small = np.pad(small, pad)
    graph = medial_graph(small)
    cand = _thin(graph)
    spots = graph.points[cand]
    geo_all = graph.distances(cand)
    geodesic = geo_all[:, cand]
    geodesic = np.where(np.isfinite(geodesic), geodesic, 1e6)
    is_end = np.isin(cand, graph.ends)
    ends = np.nonzero(is_end)[0]
    end_distance = geodesic[:, ends].min(axis=1) if len(ends) else np.zeros(len(cand))
    box = np.array([pad, pad, pad + (x1 - x0) * scale, pad + (y1 - y0) * scale])
    tree = _Tree(template, spots, geodesic, ends, end_distance, box, weights)

    _, marg = tree.solve(tree.unary)
    unary = tree.unary.copy()
    warnings = []
    leaves = tree.leaves
    if len(ends):
        # a tree end may also stay off the axis ends (a head drawn as a round blob has none): a dummy column
        # at its best energy away from every axis end
        away = end_distance > END_REACH * tree.size
        off = np.array([marg[j][away].min() if away.any() else np.inf for j in leaves])
        branch = graph.branch[np.searchsorted(graph.ends, cand[ends])] / tree.size
        claimed = marg[np.ix_(leaves, ends)] - weights.claim * branch[None, :]
        cost = np.concatenate([claimed, np.repeat(off[:, None], len(leaves), axis=1)], axis=1)
        rows, cols = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e12))
        for r, c in zip(rows, cols):
            j = leaves[r]
            if c < len(ends):
                unary[j] = np.where(np.arange(len(cand)) == ends[c], unary[j], np.inf)
            else:
                unary[j] = np.where(away, unary[j], np.inf)
    best, marg = tree.solve(unary)
    energy = marg[tree.root].min()

    # confidence: the cheapest fit with the joint at least a tenth of the character away from its spot
    far = np.linalg.norm(spots[None] - spots[best][:, None], axis=2) > 0.1 * tree.size
    gap = np.array([(marg[j][far[j]].min() if far[j].any() else np.inf) - energy for j in range(len(best))])
    confidence = 1.0 - np.exp(-np.maximum(gap, 0.0) / weights.gap_scale)

    pos = _leaf_centres(graph, cand, best, tree)
    positions = np.c_[(pos[:, 0] - pad) / scale + x0, (pos[:, 1] - pad) / scale + y0]
    low = [template.joints[j] for j in range(len(best)) if confidence[j] < 0.3]
    if low:
        warnings.append(f"unsure where {', '.join(low)} go: check them in the editor")
    return Placement(joints=template.joints, parents=tuple(int(p) for p in template.parents), positions=positions,
                     confidence=confidence, box=(x0, y0, x1, y1), warnings=warnings)
