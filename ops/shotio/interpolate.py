"""Skeleton interpolation between given poses: per bone, along the hierarchy (SHOT_FORMAT.md `frames`)."""
from __future__ import annotations

import math

import numpy as np


def _topological_order(parents: np.ndarray) -> list[int]:
    """Joints ordered so that every parent comes before its children."""
    depth = np.zeros(len(parents), dtype=np.int64)
    for i in range(len(parents)):
        j = i
        while parents[j] != -1:
            j = parents[j]
            depth[i] += 1
    return list(np.argsort(depth, kind="stable"))


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


def interpolate_pose(a: np.ndarray, b: np.ndarray, s: float, parents: np.ndarray) -> np.ndarray:
    """(J, 3) pose at fraction s between poses a and b: per-bone relative angle (shortest arc)
    and length along the hierarchy, root position and depths linear; never joint positions linearly."""
    la, lena = _local_angles(a, parents)
    lb, lenb = _local_angles(b, parents)
    dtheta = (lb - la + math.pi) % (2 * math.pi) - math.pi
    local = la + s * dtheta
    length = (1 - s) * lena + s * lenb
    out = np.empty_like(a)
    out[:, 2] = (1 - s) * a[:, 2] + s * b[:, 2]
    world = np.zeros(len(parents))
    for c in _topological_order(parents):
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
    for i, t in enumerate(out_times):
        k = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2))
        s = float((t - times[k]) / (times[k + 1] - times[k]))
        out[i] = poses[k] if s <= 0 else poses[k + 1] if s >= 1 else interpolate_pose(poses[k], poses[k + 1], s, parents)
    return out
