"""Motion across keys (docs/shot-format.md, v2): the skeleton through every given pose on one C1 curve per bone.

Each given pose is turned into per-bone parameters (the bone's angle relative to its parent's, its length),
the root's position and every joint's depth; a Catmull-Rom curve (cubic Hermite, tangents from the
neighbouring given poses, knots at their frames) runs through each parameter over the whole shot, so the
motion has no kink at a key; angles are unwrapped along the poses so each step takes the shorter arc, as the
v1 interpolation between two poses does (ops/shotio/interpolate.py). With two given poses the curve is that
interpolation exactly: linear in every parameter.

A segment's `ease` retimes it without moving a given pose: `out` leaves the segment's first key slowly (the
span after it starts at rest), `in` arrives at its last key slowly (the span before it ends at rest),
`in-out` both; the animator's slow out and slow in. Spans between given poses inside a segment keep their
timing.
"""
from __future__ import annotations

import numpy as np

from ops.shotio.interpolate import _local_angles, _topological_order
from ops.types import EASES


def pose_parameters(poses: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """(P, 3J + 2) per pose: relative angle of each joint's bone (radians, unwrapped along the poses), bone
    length (pixels), the root's x, y, and every joint's depth z; from poses (P, J, 3)."""
    J = len(parents)
    root = int(np.nonzero(np.asarray(parents) < 0)[0][0])
    out = np.empty((len(poses), 3 * J + 2))
    for i, pose in enumerate(poses):
        local, length = _local_angles(pose, parents)
        if i:  # the shorter arc from the previous pose, as interpolate_pose turns
            prev = out[i - 1, :J]
            local = prev + (local - prev + np.pi) % (2 * np.pi) - np.pi
        out[i, :J], out[i, J:2 * J] = local, length
        out[i, 2 * J:2 * J + 2] = pose[root, :2]
        out[i, 2 * J + 2:] = pose[:, 2]
    return out


def pose_from_parameters(params: np.ndarray, parents: np.ndarray, order: list[int] | None = None) -> np.ndarray:
    """(J, 3) pose from one row of pose_parameters: forward kinematics down the hierarchy."""
    J = len(parents)
    local, length = params[:J], np.maximum(params[J:2 * J], 0.0)  # a curve may overshoot a length below 0
    out = np.empty((J, 3))
    out[:, 2] = params[2 * J + 2:]
    world = np.zeros(J)
    for c in order if order is not None else _topological_order(parents):
        p = parents[c]
        if p < 0:
            out[c, :2] = params[2 * J:2 * J + 2]
            continue
        world[c] = local[c] + (world[p] if parents[p] >= 0 else 0.0)
        out[c, :2] = out[p, :2] + length[c] * np.array([np.cos(world[c]), np.sin(world[c])])
    return out


class CubicHermite:
    """Piecewise cubic Hermite curve through values (P, D) at strictly increasing knots (P,) with slopes (P, D);
    NumPy only (scipy.interpolate would cost every command that loads a shot half a second of imports)."""

    def __init__(self, knots: np.ndarray, values: np.ndarray, slopes: np.ndarray):
        self.k, self.v, self.m = knots, values, slopes

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """(Q, D) values at x (Q,) inside [knots[0], knots[-1]]."""
        i = np.clip(np.searchsorted(self.k, x, side="right") - 1, 0, len(self.k) - 2)
        h = (self.k[i + 1] - self.k[i])[:, None]
        u = ((x - self.k[i])[:, None]) / h
        h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
        h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
        return h00 * self.v[i] + h10 * h * self.m[i] + h01 * self.v[i + 1] + h11 * h * self.m[i + 1]


def catmull_rom(knots: np.ndarray, values: np.ndarray) -> CubicHermite:
    """C1 curve through values (P, D) at strictly increasing knots (P,): tangents (v[i+1] - v[i-1]) /
    (k[i+1] - k[i-1]), one-sided at the ends (so two points give a straight line)."""
    k = np.asarray(knots, np.float64)
    v = np.asarray(values, np.float64)
    if len(k) == 1:
        k, v = np.array([k[0], k[0] + 1.0]), np.concatenate([v, v])
    m = np.empty_like(v)
    m[0] = (v[1] - v[0]) / (k[1] - k[0])
    m[-1] = (v[-1] - v[-2]) / (k[-1] - k[-2])
    m[1:-1] = (v[2:] - v[:-2]) / (k[2:] - k[:-2])[:, None]
    return CubicHermite(k, v, m)


def _slow_out(u: np.ndarray) -> np.ndarray:
    """Warp of [0, 1] at rest at 0 and at unit speed at 1 (2u^2 - u^3): leaves slowly, arrives at full speed."""
    return 2 * u**2 - u**3


def eased_clock(frames: np.ndarray, knots: np.ndarray, start: float, end: float, ease: str) -> np.ndarray:
    """The curve's parameter at each output frame (Q,) of the segment [start, end] under `ease`.

    knots: every given pose's frame; the spans between the ones in [start, end] are warped at the segment's
    ends only, each onto itself, so every given pose stays at its own frame.
    """
    if ease not in EASES:
        raise ValueError(f"ease {ease!r}: use one of {EASES}")
    f = np.asarray(frames, np.float64)
    if ease == "linear":
        return f.copy()
    inner = np.asarray(knots, np.float64)
    inner = np.unique(np.concatenate([[start, end], inner[(inner > start) & (inner < end)]]))
    out = f.copy()
    spans = list(zip(inner[:-1], inner[1:]))
    for i, (a, b) in enumerate(spans):
        first, last = i == 0, i == len(spans) - 1
        leave = first and ease in ("out", "in-out")
        arrive = last and ease in ("in", "in-out")
        if not (leave or arrive):
            continue
        sel = (f >= a) & (f <= b)
        u = (f[sel] - a) / (b - a)
        if leave and arrive:
            w = 3 * u**2 - 2 * u**3  # smoothstep: at rest at both ends
        elif leave:
            w = _slow_out(u)
        else:
            w = 1 - _slow_out(1 - u)
        out[sel] = a + w * (b - a)
    return out


def interpolate_motion(knots: np.ndarray, given: np.ndarray, key_frames: tuple[int, ...], ease: tuple[str, ...],
                       parents: np.ndarray, n_frames: int) -> np.ndarray:
    """(F, J, 3) poses at output frames 0 .. n_frames - 1 from given poses (P, J, 3) at frames knots (P,).

    One Catmull-Rom curve per parameter through all given poses (not per segment), each segment retimed by its
    ease (one entry per segment; a one-key shot has one segment, the whole motion). A given pose at an integer
    frame is that output frame's pose exactly.
    """
    knots = np.asarray(knots, np.float64)
    curve = catmull_rom(knots, pose_parameters(given, parents))
    frames = np.arange(n_frames, dtype=np.float64)
    bounds = list(key_frames) + ([n_frames - 1] if len(key_frames) == 1 else [])
    clock = frames.copy()
    for s, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        sel = (frames >= a) & (frames <= b)
        clock[sel] = eased_clock(frames[sel], knots, float(a), float(b), ease[s])
    order = _topological_order(parents)
    params = curve(np.clip(clock, knots[0], knots[-1]))
    out = np.stack([pose_from_parameters(p, parents, order) for p in params])
    exact = np.nonzero((knots == np.round(knots)) & (knots < n_frames))[0]
    out[knots[exact].astype(np.int64)] = given[exact]
    return out
