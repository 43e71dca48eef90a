"""Skeleton interpolation between given poses: per bone, along the hierarchy (docs/shot-format.md, `frames`)."""
from __future__ import annotations

import math

import numpy as np


def _topological_order(parents: np.ndarray) -> list[int]:
    """Joints ordered so that every parent comes before its children (stable by depth)."""
    parents = [int(p) for p in parents]
    depth = [-1] * len(parents)
    for i in range(len(parents)):
        chain = []
        j = i
        while j != -1 and depth[j] < 0:  # walk up to a joint whose depth is known (or the root's parent)
            chain.append(j)
            j = parents[j]
        d = depth[j] if j != -1 else -1
        for c in reversed(chain):
            d += 1
            depth[c] = d
    return list(np.argsort(np.asarray(depth, dtype=np.int64), kind="stable"))


def _local_angles(pose: np.ndarray, parents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per joint: bone angle relative to the parent bone (radians) and bone length (pixels)."""
    J = len(parents)
    world = np.zeros(J)
    length = np.zeros(J)
    for c in range(J):
        p = parents[c]
        if p >= 0:
            d = pose[c, :2] - pose[p, :2]
            world[c] = math.atan2(d[1], d[0])
            length[c] = math.hypot(d[0], d[1])
    local = world.copy()
    for c in range(J):
        p = parents[c]
        if p >= 0 and parents[p] >= 0:
            local[c] = world[c] - world[p]
    return local, length


def interpolate_pose(a: np.ndarray, b: np.ndarray, s: float, parents: np.ndarray,
                     order: list[int] | None = None, angles: tuple | None = None) -> np.ndarray:
    """(J, 3) pose at fraction s between poses a and b: per-bone relative angle (shortest arc)
    and length along the hierarchy, root position and depths linear; never joint positions linearly.

    `order` (_topological_order) and `angles` (_local_angles of a and of b) may be passed in precomputed:
    resample_poses computes them once per pair of poses, not once per output frame.
    """
    la, lena = angles[0] if angles else _local_angles(a, parents)
    lb, lenb = angles[1] if angles else _local_angles(b, parents)
    dtheta = (lb - la + math.pi) % (2 * math.pi) - math.pi
    local = la + s * dtheta
    length = (1 - s) * lena + s * lenb
    out = np.empty_like(a)
    out[:, 2] = (1 - s) * a[:, 2] + s * b[:, 2]
    world = np.zeros(len(parents))
    for c in order if order is not None else _topological_order(parents):
        p = parents[c]
        if p < 0:
            out[c, :2] = (1 - s) * a[c, :2] + s * b[c, :2]
            continue
        world[c] = local[c] + (world[p] if parents[p] >= 0 else 0.0)
        out[c, :2] = out[p, :2] + length[c] * np.array([math.cos(world[c]), math.sin(world[c])])
    return out


def resample_poses(times: np.ndarray, poses: np.ndarray, out_times: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """(T, J, 3) poses at out_times, interpolated per bone between the surrounding given poses."""
    out = np.empty((len(out_times), poses.shape[1], 3))
    order = _topological_order(parents)
    angles: dict[int, tuple] = {}  # given pose -> its local angles and lengths, computed once
    for i, t in enumerate(out_times):
        k = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2))
        s = float((t - times[k]) / (times[k + 1] - times[k]))
        if s <= 0 or s >= 1:
            out[i] = poses[k] if s <= 0 else poses[k + 1]
            continue
        for j in (k, k + 1):
            if j not in angles:
                angles[j] = _local_angles(poses[j], parents)
        out[i] = interpolate_pose(poses[k], poses[k + 1], s, parents, order, (angles[k], angles[k + 1]))
    return out
