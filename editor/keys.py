"""Structural edits of a shot's keys (the editor's timeline): add a key at a frame, remove one, move one in time.

Pure functions of a shot.json object: each returns a new object and never writes. The API (editor/api.py)
runs the loader's validation on the result before anything is written. A v1 shot becomes v2 on its first
structural edit (`to_v2`): its output frames, key poses and in-between poses keep their frame numbers.
Refusals are ShotError lines naming shot.json, the field and the fix.
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from ops.errors import ShotError
from ops.shotio.load import FORMAT_V2, MAX_FRAMES, MAX_KEYS

# Splitting a segment at a new key keeps its slow out on the first half and its slow in on the second;
# removing a key joins the two halves back (the inverse).
_SPLIT = {"linear": ("linear", "linear"), "in": ("linear", "in"), "out": ("out", "linear"), "in-out": ("out", "in")}


def _join(first: str, second: str) -> str:
    slow_out, slow_in = first in ("out", "in-out"), second in ("in", "in-out")
    return {(False, False): "linear", (True, False): "out", (False, True): "in", (True, True): "in-out"}[slow_out, slow_in]


def _frame(x: float) -> int | float:
    """A pose frame as shot.json writes it: an integer when whole, else 4 decimals."""
    r = round(float(x), 4)
    return int(r) if r == int(r) else r


def _refuse(file: Path, field: str, problem: str, fix: str):
    raise ShotError(file, field, problem, fix)


def key_frames(data: dict) -> list[int]:
    """The output frame of each key of a v2 object (`[0]` when a one-drawing shot leaves it out)."""
    kf = data.get("key_frames")
    return list(kf) if isinstance(kf, list) else [0]


def to_v2(data: dict, file: Path) -> dict:
    """The v2 form of a v1 object (a v2 one is returned as a copy): output frame i of the v1 shot is frame i.

    Without `frames` each v1 pose is an output frame (pose i at frame i); with `frames` F, pose t is at frame
    t (F - 1). Key 1 is at the last output frame; `frames` goes (v2 derives the frame count from key_frames).
    """
    out = copy.deepcopy(data)
    if out.get("format") == FORMAT_V2:
        return out
    poses = out.get("poses")
    if not isinstance(poses, list) or len(poses) < 2 or not all(isinstance(p, dict) and "t" in p for p in poses):
        _refuse(file, "poses", "a v1 shot needs its poses (with t) before keys can be added, removed or moved",
                "give the poses at t = 0 and t = 1 and save first")
    frames = out.pop("frames", None)
    n_out = frames if isinstance(frames, int) and not isinstance(frames, bool) and frames >= 2 else len(poses)
    for i, p in enumerate(poses):
        t = p.pop("t")
        poses[i] = {"frame": _frame(t * (n_out - 1)) if frames is not None else i, **p}
    out["format"] = FORMAT_V2
    out["key_frames"] = [0, n_out - 1]
    return out


def _pad(values: list, n: int, fill) -> list:
    return list(values) + [copy.deepcopy(fill) for _ in range(n - len(values))]


def _per_key_insert(out: dict, k: int, n: int) -> None:
    """An empty t_junctions and masks entry for a key inserted at index k (n keys before)."""
    if isinstance(out.get("t_junctions"), list):
        out["t_junctions"] = _pad(out["t_junctions"], n, [])
        out["t_junctions"].insert(k, [])
    masks = out.get("masks")
    if isinstance(masks, dict):
        if isinstance(masks.get("foreground"), list):
            masks["foreground"] = _pad(masks["foreground"], n, None)
            masks["foreground"].insert(k, None)
        if isinstance(masks.get("occlusion"), list):
            masks["occlusion"] = _pad(masks["occlusion"], n, [])
            masks["occlusion"].insert(k, [])


def _per_key_remove(out: dict, k: int) -> None:
    if isinstance(out.get("t_junctions"), list) and k < len(out["t_junctions"]):
        out["t_junctions"].pop(k)
    masks = out.get("masks")
    if isinstance(masks, dict):
        for field in ("foreground", "occlusion"):
            if isinstance(masks.get(field), list) and k < len(masks[field]):
                masks[field].pop(k)


def add_key(data: dict, file: Path, name: str, frame: int, motion: np.ndarray) -> tuple[dict, int]:
    """(new object, index of the new key): keyframe `name` at output frame `frame`.

    motion: (F, J, 3) the saved shot's pose at each of its output frames. The new key's pose is the given pose
    at that frame if there is one, else the motion's pose there, else (past the end) the last pose. Its
    T-junctions and masks start empty; the segment it splits keeps its slow out and slow in on either side.
    """
    out = to_v2(data, file)
    keys, kf = list(out["keyframes"]), key_frames(out)
    n = len(keys)
    if n >= MAX_KEYS:
        _refuse(file, "keyframes", f"the shot has {n} keys already, the most one shot may have",
                "split the shot at a key before adding more")
    if frame in kf:
        _refuse(file, "key_frames", f"frame {frame} is key{kf.index(frame)}'s already",
                "add the key at a frame without a key (or move that key first)")
    if not 0 < frame < MAX_FRAMES:
        _refuse(file, "key_frames", f"frame {frame} is outside 1..{MAX_FRAMES - 1}",
                f"add the key at a frame from 1 to {MAX_FRAMES - 1} (key0 is frame 0)")
    poses = out["poses"]
    last_pose = max(p["frame"] for p in poses)
    if n == 1 and last_pose > frame:
        _refuse(file, "key_frames", f"the drawing's motion goes on to frame {_frame(last_pose)}, after frame {frame}",
                f"add the second key at frame {int(np.ceil(last_pose))} or later (its poses end at the last key)")
    k = sum(f < frame for f in kf)
    if not any(p["frame"] == frame for p in poses):
        if frame < len(motion):
            joints = [[round(float(c), 4) for c in j] for j in motion[frame]]
        else:  # past the motion's end: the last pose, as given
            joints = copy.deepcopy(max(poses, key=lambda p: p["frame"])["joints"])
        poses.append({"frame": frame, "joints": joints})
        poses.sort(key=lambda p: p["frame"])
    ease = out.get("ease")
    if isinstance(ease, list) and n > 1 and len(ease) == n - 1:
        if k == n:
            ease.append("linear")
        else:
            ease[k - 1:k] = list(_SPLIT.get(ease[k - 1], ("linear", "linear")))
    _per_key_insert(out, k, n)
    keys.insert(k, name)
    kf.insert(k, frame)
    out["keyframes"], out["key_frames"] = keys, kf
    return out, k


def remove_key(data: dict, file: Path, k: int) -> tuple[dict, list[str]]:
    """(new object, fields dropped): the shot without key k (its image file stays in the folder).

    A middle key's pose stays as an in-between pose (the motion is unchanged). Removing key0 makes key1 the
    first key: every frame moves back by key1's frame and earlier poses go. Removing the last of three or more
    keys drops the poses after the new last key. The two segments around a middle key join, with the slow out
    of the first and the slow in of the second. `ground_truth` is dropped when output frames change meaning.
    """
    out = to_v2(data, file)
    keys, kf = list(out["keyframes"]), key_frames(out)
    n = len(keys)
    if n == 1:
        _refuse(file, "keyframes", "the shot has one key, and a shot needs one drawing",
                "add another key first, or replace the drawing")
    dropped: list[str] = []
    poses = out["poses"]
    ease = out.get("ease")
    has_ease = isinstance(ease, list) and len(ease) == n - 1
    if k == 0:
        shift = kf[1]
        out["poses"] = [{**p, "frame": _frame(p["frame"] - shift)} for p in poses if p["frame"] >= shift]
        kf = [f - shift for f in kf]
        if has_ease and n > 2:
            ease.pop(0)
    elif k == n - 1:
        if n > 2:
            out["poses"] = [p for p in poses if p["frame"] <= kf[k - 1]]
        if has_ease and n > 2:
            ease.pop()
    elif has_ease:
        ease[k - 1:k + 1] = [_join(ease[k - 1], ease[k])]
    if (k == 0 or (k == n - 1 and n > 2)) and "ground_truth" in out:
        del out["ground_truth"]  # reference frames are named by output frame: they no longer line up
        dropped.append("ground_truth")
    _per_key_remove(out, k)
    keys.pop(k)
    kf.pop(k)
    out["keyframes"], out["key_frames"] = keys, kf
    return out, dropped


def move_key(data: dict, file: Path, k: int, frame: int) -> tuple[dict, list[str]]:
    """(new object, fields dropped): key k at output frame `frame`, its pose with it.

    Key frames stay strictly increasing and key0 stays at frame 0. The in-between poses of the two segments
    around the key are retimed in proportion (they keep their order and their place within the segment).
    `ground_truth` is dropped (the frames it names now show other moments).
    """
    out = to_v2(data, file)
    kf = key_frames(out)
    n = len(kf)
    field = f"key_frames[{k}]"
    if k == 0:
        if frame == 0:
            return out, []
        _refuse(file, field, "key0 is the shot's first frame", "key0 stays at frame 0: move the other keys")
    prev_f, old = kf[k - 1], kf[k]
    next_f = kf[k + 1] if k + 1 < n else None
    if frame <= prev_f or (next_f is not None and frame >= next_f):
        span = f"{prev_f + 1}..{next_f - 1}" if next_f is not None else f"{prev_f + 1}..{MAX_FRAMES - 1}"
        _refuse(file, field, f"frame {frame} is not between key{k - 1} (frame {prev_f})"
                + (f" and key{k + 1} (frame {next_f})" if next_f is not None else ""),
                f"give a frame in {span} (keys keep their order)")
    if frame >= MAX_FRAMES:
        _refuse(file, field, f"frame {frame}: more than {MAX_FRAMES} frames", f"give a frame below {MAX_FRAMES}")

    def retime(f: float) -> int | float:
        if prev_f < f <= old:
            return _frame(prev_f + (f - prev_f) * (frame - prev_f) / (old - prev_f))
        if next_f is not None and old < f < next_f:
            return _frame(frame + (f - old) * (next_f - frame) / (next_f - old))
        return f

    out["poses"] = [{**p, "frame": frame if p["frame"] == old else retime(p["frame"])} for p in out["poses"]]
    kf[k] = frame
    out["key_frames"] = kf
    dropped = []
    if frame != old and "ground_truth" in out:
        del out["ground_truth"]
        dropped.append("ground_truth")
    return out, dropped


def upload_name(name: str, taken: set[str], suffixes: set[str], file: Path) -> str:
    """A file name for an uploaded keyframe inside the shot folder: the upload's own name made safe
    ([A-Za-z0-9._-]), with -2, -3 ... before the suffix when `taken` (files present or named) has it."""
    base = "".join(c if c.isascii() and (c.isalnum() or c in "._-") else "_" for c in Path(name).name).lstrip(".")
    stem, suffix = Path(base).stem or "key", Path(base).suffix.lower()
    if suffix not in suffixes:
        _refuse(file, "keyframes", f"upload {name[:60]!r} is not an image file name",
                f"upload a file ending in one of {', '.join(sorted(suffixes))}")
    out, i = f"{stem}{suffix}", 2
    while out in taken:
        out, i = f"{stem}-{i}{suffix}", i + 1
    return out
