"""The motion of a v2 shot.json object as the Pose view needs it: the pose at every output frame, computed as the
loader computes it (ops/shotio/motion.py), from the object being edited (saved or not), without its images."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ops.errors import ShotError
from ops.shotio.load import MAX_FRAMES, parse_poses, parse_skeleton
from ops.shotio.motion import interpolate_motion
from ops.types import EASES


def _key_frames(data: dict, file: Path, n: int) -> tuple[int, ...]:
    kf = data.get("key_frames", [0] if n == 1 else None)
    ok = (isinstance(kf, list) and len(kf) == n and all(isinstance(f, int) and not isinstance(f, bool) for f in kf)
          and kf[0] == 0 and all(b > a for a, b in zip(kf, kf[1:])) and kf[-1] < MAX_FRAMES)
    if not ok:
        raise ShotError(file, "key_frames", f"must be {n} strictly increasing integers from 0",
                        "give the output frame of each keyframe, the first 0")
    return tuple(kf)


def v2_motion(data: dict, file: Path) -> tuple[np.ndarray, np.ndarray, tuple[int, ...], np.ndarray]:
    """(given frames (P,), given poses (P, J, 3), key frames, poses (F, J, 3) at output frames 0 .. F - 1)."""
    skeleton = parse_skeleton(data, file)
    knots, given = parse_poses(data, file, skeleton, clock="frame")
    n = max(1, len(data["keyframes"]) if isinstance(data.get("keyframes"), list) else 1)
    kf = _key_frames(data, file, n)
    n_out = int(kf[-1] if n > 1 else np.floor(knots[-1])) + 1
    if n_out > MAX_FRAMES:
        raise ShotError(file, "poses", f"{n_out} output frames, more than {MAX_FRAMES}", "give fewer frames")
    missing = [f for f in kf if f not in knots]
    if missing or (n > 1 and knots[-1] > kf[-1]):
        raise ShotError(file, "poses", "needs a pose at every key frame and none after the last",
                        "give each keyframe's pose at its key frame")
    ease = data.get("ease")
    segments = max(1, n - 1)
    if not (isinstance(ease, list) and len(ease) == segments and all(e in EASES for e in ease)):
        ease = ["linear"] * segments  # the loader refuses a malformed ease at Save; the view shows linear timing
    poses = interpolate_motion(knots, given, kf, tuple(ease), skeleton.parents, n_out)
    return knots, given, kf, poses
