"""Skeleton handles of a template (§4.2): where the pose term pins the mesh, always inside the meshed domain.

Handles sit at every joint and at every sixth of every bone: with the midpoint
alone, a limb whose neighbour turns bows between its handles (a lamp's straight
arm bent by 4 px at 256 px; lamp 21.5 -> 24.5 dB, arm_cross 25.5 -> 27.6 dB).
A handle outside the domain (a joint clicked just off the drawing, or a bone
point in paper between two parts) is moved to the nearest point safely inside
it, with a warning, and keeps its offset from the skeleton in the frame of its
bone: its target at any pose is the skeleton point plus that offset turned
with the bone, so at the keyframe's own pose every target is exactly where the
handle is drawn (the rest mesh needs no deformation and the keyframe is
reproduced). Every component of the domain that a bone crosses gets a handle
on that bone, so a hand drawn apart from its arm follows the arm instead of
floating at rest.

A coarse skeleton's bone need not run along what it moves: a hand parented to
the torso (no elbow) crosses the paper between the body and the bent arm, and
its handles, snapped to the nearest drawing, would pin the belly to the arm.
A bone whose straight line crosses paper between drawn stretches for more than
STRAY_FRACTION of its length has its handles on the drawn limb instead: at the same fractions of the
shortest path inside the drawing between its two joints (kept off the
outlines), each keeping its offset from its skeleton point as every handle does,
so the keyframe is still reproduced exactly and the limb turns with its bone.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy import ndimage
from skimage.graph import route_through_array

from ops.geometry.polygon import project_to_segment
from ops.geometry.snap import snap_into
from ops.types import MIN_BONE_PX, Skeleton, bone_frames
from ops.warning_subject import about

SAFE_INSET_PX = 2  # snapped handles land this far inside the domain's raster (its outlines are DP-simplified by 1 px)
BONE_SAMPLES = 33  # points tried along a bone when a component needs a handle
BONE_FRACTIONS = (1 / 6, 2 / 6, 0.5, 4 / 6, 5 / 6)  # handles along each bone besides its joints
STRAY_FRACTION = 0.25  # a bone whose line crosses paper for more of its length: handles on the drawn limb
FAR_PART_PX, FAR_PART_SHARE = 10.0, 0.5  # a part no bone crosses this far from the bone it follows (px, or share of
#                                          that bone's length, whichever is more) is named in a warning
MAX_DETOUR = 3.0  # the drawn limb may be at most this many times the bone's length (else the bone line is kept)


@dataclass
class Handles:
    """Handle points and how they follow the skeleton: target(pose) = W @ joints + offset turned with the bone."""

    points: np.ndarray  # (h, 2) float64 rest positions, pixels
    weights: np.ndarray  # (h, J) float64 skeleton point of each handle = weights @ joints_xy
    offsets: np.ndarray  # (h, 2) float64 (along, across) the handle's bone, pixels, from its skeleton point
    frames: np.ndarray  # (h, 2) int64 joints (parent, child) of the bone that carries the offset, -1 if none
    names: list[str]
    warnings: list[str] = field(default_factory=list)


def handle_points(pose: np.ndarray, skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Joint handles and handles at BONE_FRACTIONS along each bone: (points (J + f B, 2) pixels,
    weights (J + f B, J), names)."""
    J = len(skeleton.joints)
    bones = skeleton.bones
    xy = np.asarray(pose, dtype=np.float64)[:, :2]
    W = np.zeros((J + len(BONE_FRACTIONS) * len(bones), J))
    W[np.arange(J), np.arange(J)] = 1.0
    names = list(skeleton.joints)
    for i, u in enumerate(BONE_FRACTIONS):
        rows = J + i * len(bones) + np.arange(len(bones))
        W[rows, bones[:, 0]] = 1.0 - u
        W[rows, bones[:, 1]] += u
        names += [f"{skeleton.joints[a]}-{skeleton.joints[b]} at {u:.2f}" for a, b in bones]
    return W @ xy, W, names


def handle_bones(W: np.ndarray, skeleton: Skeleton) -> list[np.ndarray]:
    """Per handle (rows of W (h, J)), the (b,) int64 bones it lies on: a joint lies on every bone it ends."""
    bones = skeleton.bones
    on = (W[:, bones[:, 0]] + W[:, bones[:, 1]] > 1.0 - 1e-9) & ((W[:, bones[:, 0]] > 0) | (W[:, bones[:, 1]] > 0))
    return [np.nonzero(row)[0] for row in on]


def _frame_of(W: np.ndarray, skeleton: Skeleton, xy: np.ndarray) -> np.ndarray:
    """(h, 2) int64 joints of the bone each handle's offset turns with: its own bone, else a longer one it ends."""
    bones = skeleton.bones
    out = np.full((len(W), 2), -1, np.int64)
    length = np.linalg.norm(xy[bones[:, 1]] - xy[bones[:, 0]], axis=1)
    for h, on in enumerate(handle_bones(W, skeleton)):
        on = [b for b in on if length[b] > MIN_BONE_PX]
        if on:
            out[h] = bones[max(on, key=lambda b: length[b])]
    return out


def domain_mask(domain: list[np.ndarray], shape: tuple[int, int]) -> np.ndarray:
    """(H, W) bool pixel centres inside an odd number of the domain's closed polylines (pixels)."""
    mask = np.zeros(shape, np.uint8)
    for loop in domain:
        layer = np.zeros(shape, np.uint8)
        cv2.fillPoly(layer, [np.round(np.asarray(loop) * 16).astype(np.int32).reshape(-1, 1, 2)], 1, cv2.LINE_8, 4)
        mask ^= layer
    return mask.astype(bool)


def place_handles(pose: np.ndarray, skeleton: Skeleton, domain: list[np.ndarray], shape: tuple[int, int]) -> Handles:
    """Joint and midpoint handles of a (J, 3) pose moved safely inside the domain (closed polylines, pixels, in an
    (H, W) image), plus one handle for every component no handle reaches: on a bone that crosses it, or, where
    none does (a stroke of an outline drawn in pieces beside its bone), at its deepest point, following the
    nearest bone with its offset from it."""
    P, W, names = handle_points(pose, skeleton)
    xy = np.asarray(pose, np.float64)[:, :2]
    inside = domain_mask(domain, shape)
    safe = ndimage.binary_erosion(inside, iterations=SAFE_INSET_PX)
    safe = safe if safe.any() else inside
    labels, n = ndimage.label(safe, structure=np.ones((3, 3), bool))
    snapped, moved = snap_into(safe, P)
    warnings: list[str] = []
    dist = ndimage.distance_transform_edt(safe)
    drawn = np.where(moved[:, None], snapped, P)
    on_limb = _handles_on_drawn_limbs(drawn, xy, skeleton, inside, safe, dist, warnings)
    for i in np.nonzero(moved & ~on_limb)[0]:  # a handle placed on a drawn limb was not snapped
        c, r = int(np.clip(round(P[i, 0]), 0, shape[1] - 1)), int(np.clip(round(P[i, 1]), 0, shape[0] - 1))
        if not inside[r, c] or not (0 <= P[i, 0] <= shape[1] - 1 and 0 <= P[i, 1] <= shape[0] - 1):
            d = float(np.linalg.norm(snapped[i] - P[i]))
            warnings.append(about("handle", f"was {d:.1f} px outside the drawing; moved to its nearest point",
                                  name=names[i], at=P[i]))
    P = drawn
    covered = set(labels[P[:, 1].round().astype(int), P[:, 0].round().astype(int)].tolist())
    extra_P, extra_W, extra_names = [], [], []
    u = np.linspace(0.0, 1.0, BONE_SAMPLES)
    for comp in sorted(set(range(1, n + 1)) - covered):
        best = None  # (depth inside the component, bone, u, pixel)
        for b, (p, c) in enumerate(skeleton.bones):
            pts = xy[p] + u[:, None] * (xy[c] - xy[p])
            cc = np.clip(np.round(pts[:, 0]).astype(int), 0, shape[1] - 1)
            rr = np.clip(np.round(pts[:, 1]).astype(int), 0, shape[0] - 1)
            depth = np.where(labels[rr, cc] == comp, dist[rr, cc], -1.0)
            k = int(np.argmax(depth))
            if depth[k] > 0 and (best is None or depth[k] > best[0]):
                best = (depth[k], b, u[k])
        at = None  # the handle sits on the bone where the bone crosses the part, else inside the part beside it
        if best is None:  # a stroke of an outline drawn in pieces beside its bone: it follows the nearest bone
            part = labels == comp
            row, col = np.unravel_index(int(np.argmax(np.where(part, dist, -1.0))), part.shape)
            at = np.array([col, row], np.float64)
            along = (project_to_segment(at, xy[i], xy[j]) for i, j in skeleton.bones)  # (t, distance) per bone
            d_at, u_at, b_at = min((float(d), float(t), b) for b, (t, d) in enumerate(along))
            best = (0.0, b_at, u_at)
            i, j = skeleton.bones[b_at]
            if d_at > max(FAR_PART_PX, FAR_PART_SHARE * float(np.linalg.norm(xy[j] - xy[i]))):
                warnings.append(about("part of the drawing", f"({int(part.sum())} px) that no bone crosses "
                                      f"follows the nearest bone, {skeleton.joints[i]}-{skeleton.joints[j]}, "
                                      f"{d_at:.0f} px away", at=at,
                                      fix="extend a bone over it or paint it out of the mask"))
        _, b, t = best
        p, c = skeleton.bones[b]
        w = np.zeros(len(skeleton.joints))
        w[p], w[c] = 1.0 - t, t
        extra_P.append(w @ xy if at is None else at)
        extra_W.append(w)
        extra_names.append(f"{skeleton.joints[p]}-{skeleton.joints[c]} at {t:.2f} (a separate part of the drawing"
                           + (")" if at is None else ", beside the bone)"))
    if extra_P:
        P, W, names = np.vstack([P, extra_P]), np.vstack([W, extra_W]), names + extra_names
    frames = _frame_of(W, skeleton, xy)
    along, across = bone_frames(xy, frames)
    off = P - W @ xy
    offsets = np.stack([(off * along).sum(1), (off * across).sum(1)], axis=1)
    return Handles(P, W, offsets, frames, names, warnings)


def drawn_path(safe: np.ndarray, dist: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """(m, 2) pixels (x, y) of the shortest path from a to b (each (2,) pixels, inside `safe` (H, W) bool) that
    stays inside it, pulled off the outlines (a step costs 1 + 2 / (1 + its distance to them), dist (H, W) px);
    None if no path joins them."""
    cost = np.where(safe, 1.0 + 2.0 / (1.0 + dist), np.inf)
    h, w = safe.shape
    start, end = ((int(np.clip(round(p[1]), 0, h - 1)), int(np.clip(round(p[0]), 0, w - 1))) for p in (a, b))
    if not (safe[start] and safe[end]):
        return None
    try:
        rc, _ = route_through_array(cost, start, end, fully_connected=True, geometric=True)
    except ValueError:  # a and b in different parts of the drawing
        return None
    return np.asarray(rc, np.float64)[:, ::-1]


def _handles_on_drawn_limbs(P: np.ndarray, xy: np.ndarray, skeleton: Skeleton, inside: np.ndarray,
                            safe: np.ndarray, dist: np.ndarray, warnings: list[str]) -> np.ndarray:
    """Move the BONE_FRACTIONS handles of every bone whose straight line strays from the drawing onto the drawn
    path between its (already snapped) joint handles, in place in P (J + f B, 2); xy (J, 2) the joints. Returns
    the (J + f B,) bool handles so placed; appends one warning per such bone."""
    J, bones = len(skeleton.joints), skeleton.bones
    placed = np.zeros(len(P), bool)
    u = np.linspace(0.0, 1.0, BONE_SAMPLES)[1:-1]
    h, w = inside.shape
    for bi, (p, c) in enumerate(bones):
        length = float(np.linalg.norm(xy[c] - xy[p]))
        if length <= MIN_BONE_PX:
            continue
        pts = xy[p] + u[:, None] * (xy[c] - xy[p])
        cc, rr = np.round(pts[:, 0]).astype(int), np.round(pts[:, 1]).astype(int)
        on = np.zeros(len(u), bool)
        ok = (cc >= 0) & (cc < w) & (rr >= 0) & (rr < h)
        on[ok] = inside[rr[ok], cc[ok]]
        drawn = np.flatnonzero(on)
        # only paper between drawn stretches counts: a joint clicked beyond the outline is snapped, not a detour
        stray = float((~on[drawn[0]:drawn[-1] + 1]).sum()) / len(u) if len(drawn) else 0.0
        if stray <= STRAY_FRACTION:
            continue
        path = drawn_path(safe, dist, P[p], P[c])
        if path is None or len(path) < 2:
            continue
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
        if arc[-1] > MAX_DETOUR * length:
            continue
        rows = J + np.arange(len(BONE_FRACTIONS)) * len(bones) + bi
        P[rows] = np.stack([np.interp(np.asarray(BONE_FRACTIONS) * arc[-1], arc, path[:, k]) for k in (0, 1)], 1)
        placed[rows] = True
        warnings.append(about("bone", f"crosses paper for {100 * stray:.0f}% of its length; its handles follow the "
                              "drawn limb between its joints", name=f"{skeleton.joints[p]}-{skeleton.joints[c]}",
                              at=xy[p] + 0.5 * (xy[c] - xy[p]),
                              fix="add a joint where the drawn limb bends (an elbow, a knee) to steer it exactly"))
    return placed
