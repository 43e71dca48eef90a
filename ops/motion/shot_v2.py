"""Writing shot.json version 2 (docs/shot-format.md, "Version 2"): new shots, v1 shots upgraded, poses replaced.

Only what `inbetween new` and `inbetween motion` write: a v2 object with `format`, `keyframes`,
`key_frames`, `skeleton`, `poses` (`frame` per pose, one at every key frame), and one entry per key in
`t_junctions` and `masks`. Fields it does not touch (ease, ground_truth, ...) are kept as given.
"""
from __future__ import annotations

import copy
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from ops.errors import ShotError
from ops.shotio.atomic import replace_into

FORMAT_V1 = "inbetween-shot/1"
FORMAT_V2 = "inbetween-shot/2"


def pose_json(frame: float, joints: np.ndarray) -> dict:
    """One pose entry: frame (an int when whole) and [x, y, z] per joint, x y rounded to 0.01 px, z to 0.001."""
    f = float(frame)
    rows = [[round(float(x), 2), round(float(y), 2), round(float(z), 3)] for x, y, z in np.asarray(joints, np.float64)]
    return {"frame": int(f) if f.is_integer() else round(f, 4), "joints": rows}


def new_shot(keyframes: list[str], key_frames: list[int], joints: tuple[str, ...], parents: tuple[int, ...],
             pose_frames: list[float], poses: np.ndarray, foreground: list[str | None] | None = None) -> dict:
    """A v2 shot object: N keyframes at key_frames, poses (P, J, 3) at pose_frames (every key frame among them)."""
    n = len(keyframes)
    if len(key_frames) != n or list(key_frames) != sorted(set(key_frames)) or key_frames[0] != 0:
        raise ValueError(f"key frames {key_frames} for {n} keyframes")
    missing = [k for k in key_frames if k not in pose_frames]
    if missing:
        raise ValueError(f"no pose at key frames {missing}")
    return {
        "format": FORMAT_V2,
        "keyframes": list(keyframes),
        "key_frames": [int(k) for k in key_frames],
        "skeleton": {"joints": list(joints), "parents": [int(p) for p in parents]},
        "poses": [pose_json(f, p) for f, p in zip(pose_frames, poses)],
        "t_junctions": [[] for _ in range(n)],
        "masks": {"foreground": list(foreground) if foreground else [None] * n, "occlusion": [[] for _ in range(n)]},
    }


def _one_per_key(out: dict) -> dict:
    """t_junctions and masks with one entry per keyframe (v1 allows them missing or short)."""
    n = len(out.get("keyframes") or [])
    tj = list(out.get("t_junctions") or [])
    out["t_junctions"] = (tj + [[] for _ in range(n)])[:n]
    masks = dict(out.get("masks") or {})
    fg, occ = list(masks.get("foreground") or []), list(masks.get("occlusion") or [])
    masks["foreground"] = (fg + [None] * n)[:n]
    masks["occlusion"] = (occ + [[] for _ in range(n)])[:n]
    out["masks"] = masks
    return out


def as_v2(data: dict, file: str | Path) -> tuple[dict, list[str]]:
    """(a v2 copy of a v1 or v2 shot object, warnings). A v1 shot keeps its meaning: output frame i shows its
    pose i (a `frames` count with two poses puts them at frames 0 and frames - 1, the loader interpolating)."""
    fmt = data.get("format")
    if fmt == FORMAT_V2:
        out = copy.deepcopy(data)
        out.setdefault("key_frames", [0])
        return _one_per_key(out), []
    if fmt != FORMAT_V1:
        raise ShotError(file, "format", f"{fmt!r} is neither {FORMAT_V1!r} nor {FORMAT_V2!r}",
                        "start the shot with `inbetween new`, or fix the format field")
    out = {k: copy.deepcopy(v) for k, v in data.items() if k not in ("poses", "frames")}
    out["format"] = FORMAT_V2
    poses = data.get("poses") or []
    warnings = []
    frames = data.get("frames")
    if isinstance(frames, int) and not isinstance(frames, bool) and frames >= 2 and len(poses) == 2:
        at = [0, frames - 1]
    else:
        at = list(range(len(poses)))
        t = np.array([float(p.get("t", 0.0)) for p in poses]) if poses else np.zeros(0)
        if len(t) > 2 and np.abs(np.diff(t) - 1.0 / (len(t) - 1)).max() > 1e-6:
            warnings.append("the v1 poses' t were not evenly spaced: as v2, output frame i still shows pose i")
    out["poses"] = [{"frame": f, "joints": copy.deepcopy(p.get("joints"))} for f, p in zip(at, poses)]
    out["key_frames"] = [0, at[-1]] if at else [0, 0]
    return _one_per_key(out), warnings


def key_poses(data: dict, file: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(key frames (K,) int64, key poses (K, J, 3) float64) of a v2 shot object; ShotError when one is missing."""
    kf = np.asarray(data.get("key_frames", [0]), np.int64)
    by_frame = {}
    for p in data.get("poses", []):
        try:
            by_frame[float(p["frame"])] = np.asarray(p["joints"], np.float64)
        except (KeyError, TypeError, ValueError):
            raise ShotError(file, "poses", "an entry has no frame or no joints", "give {frame, joints} per pose") from None
    missing = [int(k) for k in kf if float(k) not in by_frame]
    if missing:
        raise ShotError(file, "poses", f"no pose at key frame(s) {missing}", "give the drawn pose at every key frame")
    poses = np.stack([by_frame[float(k)] for k in kf])
    return kf, poses


def write_json(path: str | Path, data: dict) -> Path:
    """Write a JSON object atomically (temp file + rename): a reader never sees half a file."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1)
            f.write("\n")
        replace_into(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
