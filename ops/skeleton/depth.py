"""Joint depths read off a drawing: where two body parts overlap, the one whose outline is drawn across the other
is in front (smaller z; larger z = farther).

For every pair of bones that share no joint and whose bodies overlap on the silhouette, each bone's outline
is looked for inside the other's body: samples along both sides of the bone, at about its body radius from
its axis, that lie well inside the other part, hit an edge of the drawing (an ink line or a colour boundary,
Canny) running along the bone. The front part's outline continues across the back part; the back part's
outline stops at the front one's. The pair is decided when one score exceeds the other by MARGIN.

Decisions become bone depths (a bone in front of another gets a smaller depth; contradictions resolved in
favour of the stronger evidence), then joint z along the hierarchy so that each decided bone's mean joint z
is its depth; an undecided bone keeps its parent joint's z.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from ops.motion.fit import parents_first
from ops.segmentation.bones import bone_radii
from ops.types import Skeleton

SAMPLES = 48  # positions along a bone
BAND = (0.7, 1.3)  # the outline is looked for between these multiples of the body radius from the axis
INSIDE = 0.6  # a sample counts when it lies within this share of the other part's radius of its axis, between
END_CAP = 0.1  # ... this share of the other bone's length from either of its ends (joint regions are not occlusions)
ALONG_COS = 0.5  # an edge runs along the bone when its gradient is within 60 degrees of the bone's normal
MIN_SAMPLES = 6  # outline samples inside the other part needed to judge
MARGIN = 0.25  # the front score must exceed the back score by this much
CANNY = (40, 110)


@dataclass
class DepthOrder:
    """Which part is drawn over which, and the joint depths that say so."""

    z: np.ndarray  # (J,) float64 joint depth, larger = farther
    decisions: list[tuple[int, int, float, float]] = field(default_factory=list)  # (front bone, back bone, scores)


def edge_map(drawing: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(H, W) bool edges of a (H, W, C) float32 drawing (any channel's Canny) and their (H, W) gradient dx, dy."""
    rgb = np.clip(drawing[..., :3] if drawing.ndim == 3 else drawing[..., None].repeat(3, 2), 0, 1)
    u8 = np.ascontiguousarray((rgb * 255).round().astype(np.uint8))
    edges = np.zeros(u8.shape[:2], bool)
    gx = np.zeros(u8.shape[:2], np.float32)
    gy = np.zeros(u8.shape[:2], np.float32)
    for c in range(3):
        ch = cv2.GaussianBlur(u8[..., c], (0, 0), 1.0)
        edges |= cv2.Canny(ch, *CANNY) > 0
        dx, dy = cv2.Sobel(ch, cv2.CV_32F, 1, 0), cv2.Sobel(ch, cv2.CV_32F, 0, 1)
        stronger = dx * dx + dy * dy > gx * gx + gy * gy
        gx, gy = np.where(stronger, dx, gx), np.where(stronger, dy, gy)
    edges = cv2.dilate(edges.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # a line's two sides, 1 px slack
    return edges, gx, gy


def _inside(points: np.ndarray, a: np.ndarray, b: np.ndarray, reach: float) -> np.ndarray:
    """(...,) bool points within reach of segment a-b, away from its end caps."""
    d = b - a
    L2 = max(float(d @ d), 1e-12)
    t = ((points - a) @ d) / L2
    dist = np.linalg.norm(points - (a + np.clip(t, 0.0, 1.0)[..., None] * d), axis=-1)
    return (dist <= reach) & (t > END_CAP) & (t < 1.0 - END_CAP)


def outline_score(a0: np.ndarray, a1: np.ndarray, ra: float, b0: np.ndarray, b1: np.ndarray, rb: float,
                  edges: np.ndarray, gx: np.ndarray, gy: np.ndarray) -> tuple[float, int]:
    """(share of bone a's outline samples inside bone b's body that lie on an edge along a, sample count)."""
    d = a1 - a0
    length = float(np.linalg.norm(d))
    if length < 1e-6:
        return 0.0, 0
    u = d / length
    n = np.array([-u[1], u[0]])
    t = np.linspace(0.1, 0.9, SAMPLES)
    offsets = np.linspace(BAND[0], BAND[1], 5) * ra
    h, w = edges.shape
    hits, count = 0, 0
    for side in (-1.0, 1.0):
        line = a0 + t[:, None] * d  # (S, 2)
        pts = line[:, None, :] + side * offsets[None, :, None] * n  # (S, O, 2)
        inside = _inside(line + side * ra * n, b0, b1, INSIDE * rb)
        col = np.clip(np.round(pts[..., 0]).astype(int), 0, w - 1)
        row = np.clip(np.round(pts[..., 1]).astype(int), 0, h - 1)
        g = np.stack([gx[row, col], gy[row, col]], -1)
        gn = np.linalg.norm(g, axis=-1)
        along = np.abs(g @ n) >= ALONG_COS * np.maximum(gn, 1e-6)
        on = (edges[row, col] & along).any(axis=1)
        hits += int((on & inside).sum())
        count += int(inside.sum())
    return (hits / count if count else 0.0), count


def _near(bones: np.ndarray, i: int, j: int) -> bool:
    """Bones that share a joint or are joined by one bone between them: they overlap at a joint, not in depth."""
    a, b = set(bones[i].tolist()), set(bones[j].tolist())
    if a & b:
        return True
    return any(set(k.tolist()) & a and set(k.tolist()) & b for k in bones)


def depth_order(drawing: np.ndarray, mask: np.ndarray, pose: np.ndarray, skeleton: Skeleton) -> DepthOrder:
    """Joint z of a (J, 2+) pose on a (H, W, C) drawing with silhouette mask (H, W) bool."""
    P = np.asarray(pose, np.float64)[:, :2]
    bones = skeleton.bones
    J = len(skeleton.joints)
    radii = bone_radii(mask, np.c_[P, np.zeros(J)], skeleton)
    edges, gx, gy = edge_map(drawing)
    lengths = np.linalg.norm(P[bones[:, 1]] - P[bones[:, 0]], axis=1)
    relations = []  # (strength, front, back, scores)
    for i in range(len(bones)):
        for j in range(i + 1, len(bones)):
            if _near(bones, i, j) or lengths[i] < 2 or lengths[j] < 2:
                continue
            a0, a1, b0, b1 = P[bones[i, 0]], P[bones[i, 1]], P[bones[j, 0]], P[bones[j, 1]]
            si, ni = outline_score(a0, a1, radii[i], b0, b1, radii[j], edges, gx, gy)
            sj, nj = outline_score(b0, b1, radii[j], a0, a1, radii[i], edges, gx, gy)
            if min(ni, nj) < MIN_SAMPLES:
                continue
            if si > sj + MARGIN:
                relations.append((si - sj, i, j, si, sj))
            elif sj > si + MARGIN:
                relations.append((sj - si, j, i, sj, si))
    depth = np.zeros(len(bones))
    decided = np.zeros(len(bones), bool)
    kept = []
    for _strength, front, back, sf, sb in sorted(relations, reverse=True):
        if depth[front] < depth[back]:
            kept.append((front, back, sf, sb))
            continue
        trial = depth.copy()
        trial[front] = depth[back] - 1.0
        # a move that breaks a stronger relation already kept is a contradiction: the stronger one wins
        if all(trial[f] < trial[b] for f, b, _, _ in kept):
            depth = trial
            decided[front] = decided[back] = True
            kept.append((front, back, sf, sb))
    for f, b, _, _ in kept:
        decided[f] = decided[b] = True
    z = np.zeros(J)
    bone_of = {int(c): k for k, (_, c) in enumerate(bones)}
    for j in parents_first(skeleton.parents):
        p = int(skeleton.parents[j])
        if p < 0:
            continue
        k = bone_of[j]
        z[j] = 2.0 * depth[k] - z[p] if decided[k] else z[p]
    return DepthOrder(z=z, decisions=[(f, b, sf, sb) for f, b, sf, sb in kept])

