"""A clip fitted to a shot's drawn key poses: the key poses are met exactly, the clip's motion kept between them.

At every key frame k each driven bone gets the rotation offset that turns the clip's direction into the
drawn one (and each length factor its drawn length), the root the translation that puts it on the drawn
root; undriven bones keep their drawn angle to their parent bone. Offsets are blended linearly in frame
between consecutive keys (angles along the shorter arc) and held before the first and after the last key,
so frame k reproduces key pose k and the clip's own motion shows everywhere else. Depth likewise: the
clip's z plus the blended offset to the drawn z (no clip depth: the drawn depths blended).
"""
from __future__ import annotations

import numpy as np

from ops.motion.clip import Clip


def parents_first(parents: np.ndarray) -> list[int]:
    """Joint indices ordered so that every parent precedes its children."""
    order: list[int] = []
    placed = np.zeros(len(parents), bool)
    while len(order) < len(parents):
        for j in range(len(parents)):
            p = int(parents[j])
            if not placed[j] and (p < 0 or placed[p]):
                order.append(j)
                placed[j] = True
    return order


def wrap(a: np.ndarray | float) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, np.float64), 2 * np.pi)


def key_weights(n_frames: int, key_frames: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For every frame f: the keys (lo, hi) around it and the share s of hi, (F,) each; held outside the keys."""
    f = np.arange(n_frames, dtype=np.float64)
    kf = np.asarray(key_frames, np.float64)
    hi = np.clip(np.searchsorted(kf, f, side="right"), 1, max(len(kf) - 1, 1))
    lo = hi - 1
    if len(kf) == 1:
        return np.zeros(n_frames, np.int64), np.zeros(n_frames, np.int64), np.zeros(n_frames)
    s = np.clip((f - kf[lo]) / (kf[hi] - kf[lo]), 0.0, 1.0)
    return lo, hi, s


def _blend(values: np.ndarray, lo: np.ndarray, hi: np.ndarray, s: np.ndarray, angular: bool = False) -> np.ndarray:
    """(F, ...) per-frame blend of per-key values (K, ...); angular: along the shorter arc."""
    a, b = values[lo], values[hi]
    step = wrap(b - a) if angular else b - a
    return a + s.reshape((-1,) + (1,) * (values.ndim - 1)) * step


def bone_geometry(pose: np.ndarray, parents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(J,) world angle (radians, image axes) and (J,) length (pixels) of each joint's bone; 0 at the root."""
    P = np.asarray(pose, np.float64)[:, :2]
    d = np.where((parents >= 0)[:, None], P - P[np.maximum(parents, 0)], 0.0)
    return np.arctan2(d[:, 1], d[:, 0]), np.hypot(d[:, 0], d[:, 1])


def fit_clip(clip: Clip, parents: np.ndarray, key_frames: np.ndarray, key_poses: np.ndarray) -> np.ndarray:
    """(F, J, 3) float64 poses: the clip's F frames on the skeleton, equal to key_poses (K, J, 3) at key_frames (K,).

    key_frames are output frame indices inside 0..F-1, strictly increasing.
    """
    parents = np.asarray(parents, np.int64)
    key_frames = np.asarray(key_frames, np.int64)
    keys = np.asarray(key_poses, np.float64)
    n, J = clip.frames, len(parents)
    if len(key_frames) != len(keys) or key_frames.min() < 0 or key_frames.max() >= n:
        raise ValueError(f"key frames {key_frames.tolist()} do not lie inside the clip's {n} frames")
    lo, hi, s = key_weights(n, key_frames)
    geo = [bone_geometry(k, parents) for k in keys]
    alpha = np.stack([g[0] for g in geo])  # (K, J)
    length = np.stack([g[1] for g in geo])
    order = parents_first(parents)
    root = order[0]

    angle = np.zeros((n, J))
    size = np.zeros((n, J))
    for j in order:
        p = int(parents[j])
        if p < 0:
            continue
        if j in clip.angles:
            theta = np.asarray(clip.angles[j], np.float64)
            angle[:, j] = theta + _blend(wrap(alpha[:, j] - theta[key_frames]), lo, hi, s, angular=True)
        elif parents[p] >= 0:  # ride the parent bone at the drawn angle to it
            angle[:, j] = angle[:, p] + _blend(wrap(alpha[:, j] - alpha[:, p]), lo, hi, s, angular=True)
        else:  # a bone off the root: the drawn direction
            angle[:, j] = _blend(alpha[:, j], lo, hi, s, angular=True)
        if j in clip.scales:
            lam = np.asarray(clip.scales[j], np.float64)
            size[:, j] = lam * _blend(length[:, j] / np.maximum(lam[key_frames], 1e-9), lo, hi, s)
        else:
            size[:, j] = _blend(length[:, j], lo, hi, s)

    out = np.zeros((n, J, 3))
    out[:, root, :2] = clip.root + _blend(keys[:, root, :2] - clip.root[key_frames], lo, hi, s)
    for j in order[1:]:
        p = int(parents[j])
        out[:, j, 0] = out[:, p, 0] + size[:, j] * np.cos(angle[:, j])
        out[:, j, 1] = out[:, p, 1] + size[:, j] * np.sin(angle[:, j])
    if clip.depth is None:
        out[:, :, 2] = _blend(keys[:, :, 2], lo, hi, s)
    else:
        out[:, :, 2] = clip.depth + _blend(keys[:, :, 2] - clip.depth[key_frames], lo, hi, s)
    return out
