"""The cut an occlusion region's outline implies, for a region the user clicked no T-junction on (§4.4, extended).

Real batches arrive without clicks, and a region with no T-junction has only two cuts under the switching rule:
its front sewn all round (the covering limb cannot leave) or cut free all round (it leaves as a flap, torn from
its own continuation). Neither lets two overlapping legs part into a stride. Yet the region's outline says where
the switches belong. A region R where a front body F covers a back body B is bounded by two kinds of pieces:
- a piece of B's outline, running inside F: across it lies F's continuation, so the front stays sewn there
  (label 0);
- a piece of F's outline, running inside B: across it lies B alone, so there the pocket (B's hidden part) is
  sewn and the front cut free (label 1).
The T-junctions a user would click are where the two kinds meet. Each boundary vertex is read by the point just
outside it: within the front body's half-width of a front bone, or of a bone joined to one (the upper arm at
the elbow of a forearm region), it is F's continuation, else B's. The front body's half-width is the region's own (its distance transform along the front bones), not the foreground's,
which reads a forearm lying over a belly as thick as the belly. Points on paper (a region on the silhouette)
take their neighbours' label; runs shorter than MIN_RUN_PX are noise and join their neighbours.

The cut search (ops.geometry.topology) scores this cut beside the two uniform ones and keeps the one of least
energy: it is a candidate, not a verdict.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from ops.geometry.polygon import project_to_segment
from ops.types import Skeleton

PROBE_PX = 2.5  # the point read for a boundary vertex lies this far outside the region (its boundary is DP 2 px)
WIDTH_MARGIN_PX = 1.0  # a point within the front body's half-width plus this of a front bone continues it (a probe
#                        across the body's own side lies PROBE_PX beyond its half-width)
MIN_RUN_PX = 6.0  # shorter runs of one label along the boundary join their neighbours


def outward_probes(boundary: np.ndarray, region: np.ndarray, step: float = PROBE_PX) -> np.ndarray:
    """(n, 2) points `step` px outside the (H, W) bool region across each vertex of its closed boundary (n, 2)."""
    ahead = np.roll(boundary, -1, axis=0) - boundary
    behind = boundary - np.roll(boundary, 1, axis=0)
    tangent = (ahead / np.maximum(np.linalg.norm(ahead, axis=1, keepdims=True), 1e-9)
               + behind / np.maximum(np.linalg.norm(behind, axis=1, keepdims=True), 1e-9))
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-9)
    probes = boundary + step * normal
    if _inside(region, probes).mean() > 0.5:  # the normal pointed in: the polyline runs the other way round
        probes = boundary - step * normal
    return probes


def _inside(mask: np.ndarray, P: np.ndarray) -> np.ndarray:
    h, w = mask.shape
    c = np.clip(np.round(P).astype(np.int64), 0, [w - 1, h - 1])
    return mask[c[:, 1], c[:, 0]]


def implied_labels(boundary: np.ndarray, region: np.ndarray, foreground: np.ndarray, front_bones: np.ndarray,
                   pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(n,) int8 label of each vertex of a region's closed boundary (n, 2) pixels: 0 where the front body
    continues across it, 1 where only the body behind does. region, foreground: (H, W) bool; front_bones: (f,)
    int64; pose: (J, 3) pixels."""
    n = len(boundary)
    if n == 0 or len(front_bones) == 0:
        return np.zeros(n, np.int8)
    probes = outward_probes(boundary, region)
    depth = ndimage.distance_transform_edt(region)
    h, w = region.shape
    front = np.asarray(front_bones, np.int64)
    width = 0.0
    for b in front:
        a, c = (np.asarray(pose[j, :2], np.float64) for j in skeleton.bones[b])
        along = a + np.linspace(0.0, 1.0, 64)[:, None] * (c - a)
        cells = np.clip(np.round(along).astype(np.int64), 0, [w - 1, h - 1])
        # a pixel centre's distance to the nearest pixel outside: the half-width plus about one pixel
        width = max(width, float(depth[cells[:, 1], cells[:, 0]].max()) - 1.0)
    # the front part goes on in its own bones' neighbours: the upper arm at the elbow, the hand at the wrist
    chain = np.nonzero(skeleton.adjacent_bones()[front].any(axis=0))[0]
    near = np.full(n, np.inf)
    for b in chain:
        a, c = (np.asarray(pose[j, :2], np.float64) for j in skeleton.bones[b])
        near = np.minimum(near, project_to_segment(probes, a, c)[1])
    labels = np.where(near <= width + WIDTH_MARGIN_PX, 0, 1).astype(np.int8)
    paper = ~_inside(foreground, probes)
    return _smoothed(boundary, labels, paper)


def _smoothed(boundary: np.ndarray, labels: np.ndarray, unknown: np.ndarray) -> np.ndarray:
    """labels (n,) with the unknown vertices given their nearer labelled neighbour's label along the loop, then
    runs shorter than MIN_RUN_PX (arc length) merged into their longer neighbour, shortest first."""
    n = len(labels)
    out = labels.copy()
    known = np.nonzero(~unknown)[0]
    if len(known) == 0:
        return np.zeros(n, np.int8)
    for i in np.nonzero(unknown)[0]:
        gap = np.minimum((known - i) % n, (i - known) % n)
        out[i] = labels[known[np.argmin(gap)]]
    seg = np.linalg.norm(np.roll(boundary, -1, axis=0) - boundary, axis=1)  # edge i: vertex i to i + 1
    while True:
        starts = np.nonzero(out != np.roll(out, 1))[0]
        if len(starts) < 2:
            return out
        ends = np.roll(starts, -1)
        lengths = np.array([seg[np.arange(s, e if e > s else e + n) % n].sum() for s, e in zip(starts, ends)])
        i = int(np.argmin(lengths))
        if lengths[i] >= MIN_RUN_PX:
            return out
        s, e = starts[i], ends[i]
        out[np.arange(s, e if e > s else e + n) % n] = 1 - out[s]


def switches_of(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A closed loop's per-vertex labels (n,) -> (switches (s,) int64 sorted vertex indices where the label
    changes, labels (max(s, 1),) int8 of the segment starting at each), the topology's Assignment fields."""
    labels = np.asarray(labels, np.int8)
    switches = np.nonzero(labels != np.roll(labels, 1))[0].astype(np.int64)
    if len(switches) == 0:
        return switches, labels[:1].copy() if len(labels) else np.zeros(1, np.int8)
    return switches, labels[switches].copy()
