"""Loading and validating a shot directory (docs/shot-format.md: v1, two keys; v2, any number of keys).

Every problem raises ops.errors.ShotError naming the file, the field and the fix.
Every count is bounded before any work proportional to it is done (the MAX_*
constants below), so a hostile or mistyped shot.json fails at once instead of
running for hours: `"frames": 10000000` is one line, not a hang.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from ops.errors import ShotError
from ops.shotio.image_io import MAX_SIDE, MIN_SIDE, image_size, pixel_problem
from ops.shotio.interpolate import resample_poses
from ops.shotio.motion import interpolate_motion
from ops.types import EASES, Shot, Skeleton

FORMAT = "inbetween-shot/1"
FORMAT_V2 = "inbetween-shot/2"
FORMATS = {FORMAT: 1, FORMAT_V2: 2}
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr", ".bmp", ".webp"}

# Bounds on what one shot may ask for; each is far above any real shot and far below what hangs a run.
MAX_SHOT_JSON_BYTES = 16 * 2**20  # 1000 poses of 128 joints take about 4 MB of JSON
MAX_FRAMES = 1000  # output frames, and given poses
MAX_JOINTS = 128  # rigs of 2D characters have tens; interpolation is O(joints x depth) per frame
MAX_T_JUNCTIONS = 64  # per keyframe: the topology search is exponential in the clicks of one region
MAX_MASK_FILES = 16  # manual occlusion masks per keyframe
MAX_KEYS = 16  # keyframes of one shot: the Dagster graph holds a lane per key (assets/graph.py)
MAX_SHOT_PIXELS = 2**30  # output frames x keyframe pixels: e.g. 500 frames of 1920x1080
MAX_BATCH_PIXELS = 2**32  # the sum of MAX_SHOT_PIXELS's measure over every shot of one batch
COORD_MARGIN = 4  # joint x, y may lie this many image sizes outside the image (a character leaving the frame)
MAX_DEPTH = 1e6  # |z|: only the order of depths matters
SAVE_SECONDS = 2.0  # a shot.json changed this recently may be in the middle of a save (partial text)
JSON_RETRY_SECONDS = 0.5  # how long a partial shot.json is reread before it is an error


def _show(value, limit: int = 60) -> str:
    """A short repr of a JSON value for an error line (a 4000-digit number or a 1 MB string stays short)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _resolve(root: Path, rel, file: Path, field: str) -> Path:
    """Absolute path of `rel` inside `root`; refuses paths that escape the shot directory."""
    if not isinstance(rel, str) or not rel or "\x00" in rel or len(rel) > 1024:
        raise ShotError(file, field, f"expected a relative file path, got {_show(rel)}", "give a file name inside the shot directory")
    p = (root / rel).resolve()
    if Path(rel).is_absolute() or not p.is_relative_to(root):
        raise ShotError(file, field, f"path {rel!r} escapes the shot directory", "use a path inside the shot directory")
    return p


def _image(root: Path, rel, file: Path, field: str) -> tuple[Path, tuple[int, int]]:
    """Resolved image path and its (H, W), checked from the header before any pixel is decoded."""
    p = _resolve(root, rel, file, field)
    if not p.is_file():
        raise ShotError(file, field, f"image {rel!r} does not exist", "add the file or correct the path")
    h, w = image_size(p, field)
    if h > MAX_SIDE or w > MAX_SIDE:
        raise ShotError(file, field, f"image {rel!r} is {w}x{h}, larger than {MAX_SIDE}x{MAX_SIDE}",
                        f"downscale it to at most {MAX_SIDE} px per side")
    if h < MIN_SIDE or w < MIN_SIDE:
        raise ShotError(file, field, f"image {rel!r} is {w}x{h}, smaller than {MIN_SIDE}x{MIN_SIDE}",
                        f"give a drawing of at least {MIN_SIDE} px per side")
    return p, (h, w)


def _check_pixels(p: Path, rel: str, file: Path, field: str, kind: str) -> None:
    """Decode the image once per file version: damaged data, NaN, a blank page are input errors."""
    problem = pixel_problem(p, kind)
    if problem:
        raise ShotError(file, field, f"image {rel!r}: {problem[0]}", problem[1])


def read_shot_json(shot_dir: str | Path) -> tuple[Path, dict]:
    """(path of shot.json, parsed dict); raises ShotError when missing or not JSON."""
    root = Path(shot_dir).resolve()
    file = root / "shot.json"
    if not file.is_file():
        raise ShotError(file, "shot.json", "file not found", "create shot.json in the shot directory (the format: docs/shot-format.md)")
    data = _parse_json(file)
    if not isinstance(data, dict):
        raise ShotError(file, "shot.json", "top level is not an object", "write a JSON object with the fields of docs/shot-format.md")
    return file, data


def _parse_json(file: Path):
    """The parsed JSON of `file`. A read that races a save sees partial text: while the file is being
    written (changed within SAVE_SECONDS) a failed parse is retried for up to JSON_RETRY_SECONDS."""
    start, problem = time.monotonic(), ""
    while True:
        try:
            st = file.stat()
            if st.st_size > MAX_SHOT_JSON_BYTES:
                raise ShotError(file, "shot.json", f"file is {st.st_size} bytes, more than {MAX_SHOT_JSON_BYTES}",
                                "a shot.json is a few kB to a few MB: check that this is the right file")
            raw = file.read_bytes()
        except OSError as e:
            raise ShotError(file, "shot.json", f"cannot read ({e.strerror or e})", "check the file's permissions") from None
        try:
            return json.loads(raw.decode("utf-8"))
        except UnicodeDecodeError as e:
            problem = f"not UTF-8 text ({e.reason} at byte {e.start})"
        except RecursionError:
            problem = "nested too deeply"
        except ValueError as e:  # JSONDecodeError, or an integer of more than 4300 digits
            digits = "integer string conversion" in str(e)
            problem = "a number has more than 4300 digits" if digits else " ".join(str(e).split())[:200]
        being_saved = time.time() - st.st_mtime < SAVE_SECONDS
        if not being_saved or time.monotonic() - start > JSON_RETRY_SECONDS:
            raise ShotError(file, "shot.json", f"not valid JSON ({problem})", "fix the JSON syntax")
        time.sleep(0.05)


def _count(value, limit: int, file: Path, field: str, what: str, fix: str) -> None:
    """Refuse a list longer than `limit` before any work proportional to its length."""
    if isinstance(value, list) and len(value) > limit:
        raise ShotError(file, field, f"{len(value)} {what}, more than {limit}", fix)


def parse_skeleton(data: dict, file: Path) -> Skeleton:
    """Validated skeleton: unique names, one root, parents in range, no cycle."""
    sk = data.get("skeleton")
    if not isinstance(sk, dict):
        raise ShotError(file, "skeleton", "missing or not an object", 'add {"joints": [...], "parents": [...]}')
    joints, parents = sk.get("joints"), sk.get("parents")
    _count(joints, MAX_JOINTS, file, "skeleton.joints", "joints", f"use at most {MAX_JOINTS} joints")
    if not isinstance(joints, list) or not joints or not all(isinstance(j, str) for j in joints):
        raise ShotError(file, "skeleton.joints", "must be a non-empty list of names", "list one name per joint")
    if len(set(joints)) != len(joints):
        dup = sorted({j for j in joints if joints.count(j) > 1})[:5]
        raise ShotError(file, "skeleton.joints", f"duplicate joint names {dup}", "make every joint name unique")
    if not isinstance(parents, list) or len(parents) != len(joints) or not all(isinstance(p, int) and not isinstance(p, bool) for p in parents):
        raise ShotError(file, "skeleton.parents", f"must be {len(joints)} integers (one per joint)", "give each joint's parent index, -1 for the root")
    n = len(joints)
    if any(p < -1 or p >= n for p in parents):
        raise ShotError(file, "skeleton.parents", "a parent index is out of range", f"use -1 or an index in 0..{n - 1}")
    roots = [i for i, p in enumerate(parents) if p == -1]
    if len(roots) != 1:
        raise ShotError(file, "skeleton.parents", f"{len(roots)} roots (joints with parent -1), expected exactly 1", "give exactly one joint the parent -1")
    for i in range(n):  # walking up from every joint must reach the root within n steps
        j, steps = i, 0
        while j != -1:
            j, steps = parents[j], steps + 1
            if steps > n:
                raise ShotError(file, "skeleton.parents", f"cycle through joint {joints[i]!r}", "make the parents form a tree")
    return Skeleton(tuple(joints), np.asarray(parents, dtype=np.int64))


def _finite_array(value, shape_tail: tuple[int, ...], file: Path, field: str, fix: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError):  # OverflowError: an integer beyond float range
        raise ShotError(file, field, "not a list of numbers", fix) from None
    if arr.ndim != 1 + len(shape_tail) or arr.shape[1:] != shape_tail:
        if arr.size == 0 and shape_tail == (2,):
            return np.zeros((0, 2))
        raise ShotError(file, field, f"has shape {arr.shape}, expected (n, {', '.join(map(str, shape_tail))})", fix)
    if not np.isfinite(arr).all():
        raise ShotError(file, field, "contains NaN or infinite coordinates", "replace them with finite numbers")
    return arr


def parse_poses(data: dict, file: Path, skeleton: Skeleton, clock: str = "t") -> tuple[np.ndarray, np.ndarray]:
    """(clocks (P,), joints (P, J, 3)) of the given poses, validated; clock "t" (v1: 0 first, 1 last) or "frame"
    (v2: 0 first, any number of poses, a single one allowed)."""
    poses = data.get("poses")
    least = 2 if clock == "t" else 1
    if not isinstance(poses, list) or len(poses) < least:
        if clock == "t":
            raise ShotError(file, "poses", "need at least two poses (t = 0 and t = 1)", "add the poses of both keyframes")
        raise ShotError(file, "poses", "need at least one pose", 'add {"frame": 0, "joints": [[x, y, z], ...]}')
    _count(poses, MAX_FRAMES, file, "poses", "poses", f"give at most {MAX_FRAMES} poses")
    J = len(skeleton.joints)
    times, joints = [], []
    for i, p in enumerate(poses):
        if clock == "frame" and isinstance(p, dict) and "t" in p and "frame" not in p:
            raise ShotError(file, f"poses[{i}]", "has 't', a v1 field", 'v2 poses carry "frame" (the output frame) instead of "t"')
        if not isinstance(p, dict) or clock not in p or "joints" not in p:
            raise ShotError(file, f"poses[{i}]", f"needs fields '{clock}' and 'joints'",
                            f'write {{"{clock}": ..., "joints": [[x, y, z], ...]}}')
        t = p[clock]
        try:
            finite = isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(float(t))
        except OverflowError:  # an integer of hundreds of digits
            finite = False
        if not finite:
            raise ShotError(file, f"poses[{i}].{clock}", f"{_show(t)} is not a finite number",
                            "give t in [0, 1]" if clock == "t" else "give the pose's output frame, a number >= 0")
        if not isinstance(p["joints"], list) or len(p["joints"]) != J:
            got = len(p["joints"]) if isinstance(p["joints"], list) else "no list"
            raise ShotError(file, f"poses[{i}].joints", f"has {got} joints, the skeleton has {J}", "give one [x, y, z] per skeleton joint")
        joints.append(_finite_array(p["joints"], (3,), file, f"poses[{i}].joints", "give [x, y, z] per joint"))
        times.append(float(t))
    times_arr = np.asarray(times)
    joints_arr = np.stack(joints)
    if clock == "t":
        if times_arr[0] != 0.0:
            raise ShotError(file, "poses[0].t", f"first pose has t = {times_arr[0]}, expected 0", "make the first pose the keyframe at t = 0")
        if times_arr[-1] != 1.0:
            raise ShotError(file, f"poses[{len(times) - 1}].t", f"last pose has t = {times_arr[-1]}, expected 1", "make the last pose the keyframe at t = 1")
    elif times_arr[0] != 0.0:
        raise ShotError(file, "poses[0].frame", f"first pose is at frame {times_arr[0]:g}, expected 0",
                        "give the first keyframe's pose at frame 0")
    bad = np.nonzero(np.diff(times_arr) <= 0)[0]
    if bad.size:
        i = int(bad[0]) + 1
        shown = (times_arr[i], times_arr[i - 1]) if clock == "t" else (f"{times_arr[i]:g}", f"{times_arr[i - 1]:g}")
        raise ShotError(file, f"poses[{i}].{clock}", f"{clock} = {shown[0]} does not increase after {shown[1]}",
                        f"sort the poses by strictly increasing {clock}")
    return times_arr, joints_arr


def _check_coordinates(poses: np.ndarray, size: tuple[int, int], file: Path) -> None:
    """Joints may leave the frame (a character walking out), but not by more than COORD_MARGIN image sizes."""
    h, w = size
    reach = COORD_MARGIN * max(h, w)
    x, y, z = poses[..., 0], poses[..., 1], poses[..., 2]
    far = (x < -reach) | (x > w + reach) | (y < -reach) | (y > h + reach)
    if far.any():
        i, j = (int(v[0]) for v in np.nonzero(far))
        raise ShotError(file, f"poses[{i}].joints[{j}]", f"point ({x[i, j]:.6g}, {y[i, j]:.6g}) lies more than "
                        f"{COORD_MARGIN} image sizes outside the {w}x{h} image", "give x, y in the keyframes' pixels")
    deep = np.abs(z) > MAX_DEPTH
    if deep.any():
        i, j = (int(v[0]) for v in np.nonzero(deep))
        raise ShotError(file, f"poses[{i}].joints[{j}]", f"depth z = {z[i, j]:.6g} is beyond +-{MAX_DEPTH:g}",
                        "only the order of depths matters: use small numbers")


def _per_key(n: int) -> str:
    return "two" if n == 2 else str(n)


def _parse_masks(data: dict, root: Path, file: Path, size: tuple[int, int], n: int = 2):
    """(foreground mask path or None, occlusion mask paths) per keyframe, n keyframes; shorter lists mean
    "predict it" for the keys they leave out."""
    masks = data.get("masks") or {}
    if not isinstance(masks, dict):
        raise ShotError(file, "masks", "must be an object", 'write {"foreground": [...], "occlusion": [[...], [...]]}')
    fg = masks.get("foreground") or [None] * n
    occ = masks.get("occlusion") or [[]] * n
    if not isinstance(fg, list) or len(fg) > n:
        raise ShotError(file, "masks.foreground", f"must be a list of {_per_key(n)} entries (path or null)", "give one entry per keyframe")
    if not isinstance(occ, list) or len(occ) > n:
        raise ShotError(file, "masks.occlusion", f"must be a list of {_per_key(n)} lists of paths", "give one list per keyframe")
    fg = list(fg) + [None] * (n - len(fg))
    occ = list(occ) + [[]] * (n - len(occ))
    fg_paths: list[str | None] = []
    occ_paths: list[tuple[str, ...]] = []
    for k in range(n):
        if fg[k] is None:
            fg_paths.append(None)
        else:
            p, s = _image(root, fg[k], file, f"masks.foreground[{k}]")
            if s != size:
                raise ShotError(file, f"masks.foreground[{k}]", f"mask is {s[1]}x{s[0]}, keyframes are {size[1]}x{size[0]}", "export the mask at the keyframe size")
            _check_pixels(p, fg[k], file, f"masks.foreground[{k}]", "mask")
            fg_paths.append(str(p))
        if occ[k] is None:
            occ[k] = []
        if not isinstance(occ[k], list):
            raise ShotError(file, f"masks.occlusion[{k}]", "must be a list of paths", "give a list (possibly empty)")
        _count(occ[k], MAX_MASK_FILES, file, f"masks.occlusion[{k}]", "mask files",
               f"give at most {MAX_MASK_FILES} occlusion masks per keyframe (merge regions that never touch)")
        paths = []
        for i, rel in enumerate(occ[k]):
            p, s = _image(root, rel, file, f"masks.occlusion[{k}][{i}]")
            if s != size:
                raise ShotError(file, f"masks.occlusion[{k}][{i}]", f"mask is {s[1]}x{s[0]}, keyframes are {size[1]}x{size[0]}", "export the mask at the keyframe size")
            _check_pixels(p, rel, file, f"masks.occlusion[{k}][{i}]", "mask")
            paths.append(str(p))
        occ_paths.append(tuple(paths))
    return tuple(fg_paths), tuple(occ_paths)


def _parse_t_junctions(data: dict, file: Path, size: tuple[int, int], n: int = 2) -> tuple[np.ndarray, ...]:
    """(k, 2) float64 T-junction points per keyframe, n keyframes (v2: absent = none clicked)."""
    tj = data.get("t_junctions", [[]] * n)
    if not isinstance(tj, list) or len(tj) != n:
        raise ShotError(file, "t_junctions", f"must be a list of {_per_key(n)} lists (one per keyframe)",
                        "write [[[x, y], ...], [[x, y], ...]]" if n == 2 else f"give {n} lists of [x, y] points")
    out = []
    h, w = size
    for k in range(n):
        field = f"t_junctions[{k}]"
        _count(tj[k], MAX_T_JUNCTIONS, file, field, "T-junctions",
               f"click at most {MAX_T_JUNCTIONS} T-junctions per keyframe (one per place a contour ends at another)")
        pts = _finite_array(tj[k] if tj[k] is not None else [], (2,), file, field, "give a list of [x, y] pixel points")
        outside = (pts[:, 0] < -0.5) | (pts[:, 0] > w - 0.5) | (pts[:, 1] < -0.5) | (pts[:, 1] > h - 0.5)
        if outside.any():
            i = int(np.nonzero(outside)[0][0])
            raise ShotError(file, f"{field}[{i}]", f"point {pts[i].tolist()} lies outside the {w}x{h} image", "click the T-junction on the drawing")
        out.append(pts)
    return tuple(out)


def _keyframe_images(data: dict, root: Path, file: Path, version: int) -> tuple[list[Path], tuple[int, int]]:
    """Resolved keyframe paths and their common (H, W), from the headers only."""
    keys = data.get("keyframes")
    if version == 1 and (not isinstance(keys, list) or len(keys) != 2):
        raise ShotError(file, "keyframes", "must list exactly two images", 'write "keyframes": ["key0.png", "key1.png"]')
    if version == 2 and (not isinstance(keys, list) or not keys):
        raise ShotError(file, "keyframes", "must list at least one image", 'write "keyframes": ["key0.png", ...]')
    _count(keys, MAX_KEYS, file, "keyframes", "keyframes", f"give at most {MAX_KEYS} keys (split a longer shot at a key)")
    found = [_image(root, keys[k], file, f"keyframes[{k}]") for k in range(len(keys))]
    for k, (_, s) in enumerate(found[1:], 1):
        s0 = found[0][1]
        if s != s0:
            raise ShotError(file, "keyframes", f"key0 is {s0[1]}x{s0[0]} but key{k} is {s[1]}x{s[0]}",
                            "export every keyframe at the same size" if version == 2 else "export both keyframes at the same size")
    return [p for p, _ in found], found[0][1]


def _check_output_pixels(file: Path, field: str, n_out: int, size: tuple[int, int]) -> None:
    if n_out * size[0] * size[1] > MAX_SHOT_PIXELS:
        raise ShotError(file, field, f"{n_out} frames of {size[1]}x{size[0]} are {n_out * size[0] * size[1]} pixels, "
                        f"more than {MAX_SHOT_PIXELS}", "give fewer frames or smaller keyframes")


def _timing_v1(data: dict, file: Path, skeleton: Skeleton, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """v1: (times (T,) in [0, 1], poses (T, J, 3)): the given poses, or `frames` of them interpolated per bone."""
    given_t, given = parse_poses(data, file, skeleton)
    _check_coordinates(given, size, file)
    frames = data.get("frames")
    if frames is not None and (not isinstance(frames, int) or isinstance(frames, bool) or frames < 2):
        raise ShotError(file, "frames", f"{_show(frames)} is not an integer >= 2", "give the number of output frames including both keyframes")
    if frames is not None and frames > MAX_FRAMES:
        raise ShotError(file, "frames", f"{_show(frames)} frames, more than {MAX_FRAMES}",
                        f"give at most {MAX_FRAMES} frames (split a longer shot at a key pose)")
    _check_output_pixels(file, "frames" if frames is not None else "poses", frames or len(given_t), size)
    if frames is None:
        return given_t, given
    times = np.linspace(0.0, 1.0, frames)
    return times, resample_poses(given_t, given, times, skeleton.parents)


def _key_frames(data: dict, file: Path, n: int) -> tuple[int, ...]:
    """v2 `key_frames`: n integers, the first 0, strictly increasing (optional for one key: [0])."""
    kf = data.get("key_frames")
    if kf is None and n == 1:
        return (0,)
    if kf is None:
        raise ShotError(file, "key_frames", "missing", f"give the output frame of each of the {n} keyframes, e.g. "
                        f"{list(range(0, 8 * n, 8))}")
    if (not isinstance(kf, list) or len(kf) != n
            or not all(isinstance(f, int) and not isinstance(f, bool) for f in kf)):
        raise ShotError(file, "key_frames", f"must be {n} integers (one output frame per keyframe)",
                        f"write e.g. {list(range(0, 8 * n, 8))}")
    if kf[0] != 0:
        raise ShotError(file, "key_frames[0]", f"the first keyframe is at frame {_show(kf[0])}, expected 0",
                        "put the first keyframe at frame 0")
    for i in range(1, n):
        if kf[i] <= kf[i - 1]:
            raise ShotError(file, f"key_frames[{i}]", f"frame {_show(kf[i])} does not come after {kf[i - 1]}",
                            "give strictly increasing frames, in the order of keyframes")
    if kf[-1] >= MAX_FRAMES:
        raise ShotError(file, f"key_frames[{n - 1}]", f"frame {_show(kf[-1])}: more than {MAX_FRAMES} frames",
                        f"give at most {MAX_FRAMES} frames (split a longer shot at a key)")
    return tuple(kf)


def _ease(data: dict, file: Path, n_segments: int) -> tuple[str, ...]:
    ease = data.get("ease")
    if ease is None:
        return ("linear",) * n_segments
    if not isinstance(ease, list) or len(ease) != n_segments:
        raise ShotError(file, "ease", f"must be a list of {n_segments} entries, one per segment",
                        f"give one of {', '.join(EASES)} per segment, or leave ease out")
    for i, e in enumerate(ease):
        if e not in EASES:
            raise ShotError(file, f"ease[{i}]", f"{_show(e)} is not an ease", f"use one of {', '.join(EASES)}")
    return tuple(ease)


def _timing_v2(data: dict, file: Path, skeleton: Skeleton, size: tuple[int, int], n: int
               ) -> tuple[np.ndarray, np.ndarray, tuple[int, ...], tuple[str, ...]]:
    """v2: (frame numbers (F,), poses (F, J, 3), key frames, ease per segment)."""
    if "frames" in data:
        raise ShotError(file, "frames", "is a v1 field", "in v2 the output frames follow key_frames (and, for one "
                        "drawing, the last pose's frame): remove frames")
    key_frames = _key_frames(data, file, n)
    frames, given = parse_poses(data, file, skeleton, clock="frame")
    _check_coordinates(given, size, file)
    for k, f in enumerate(key_frames):
        if f not in frames:
            raise ShotError(file, "poses", f"no pose at frame {f}, keyframe {k}'s frame",
                            "give the pose of every keyframe at its key frame")
    if n > 1 and frames[-1] > key_frames[-1]:
        i = int(np.nonzero(frames > key_frames[-1])[0][0])
        raise ShotError(file, f"poses[{i}].frame", f"frame {frames[i]:g} comes after the last key frame {key_frames[-1]}",
                        "remove the pose, or add a keyframe at or after it")
    if n == 1 and frames[-1] != round(frames[-1]):
        raise ShotError(file, f"poses[{len(frames) - 1}].frame", f"frame {frames[-1]:g} is not a whole frame",
                        "the last pose of a one-drawing shot is its last output frame: give an integer")
    n_out = int(key_frames[-1] if n > 1 else frames[-1]) + 1
    if n_out > MAX_FRAMES:
        raise ShotError(file, "poses", f"{n_out} output frames, more than {MAX_FRAMES}",
                        f"give at most {MAX_FRAMES} frames (split a longer shot at a key)")
    _check_output_pixels(file, "key_frames" if n > 1 else "poses", n_out, size)
    ease = _ease(data, file, max(1, n - 1))
    poses = interpolate_motion(frames, given, key_frames, ease, skeleton.parents, n_out)
    return np.arange(n_out, dtype=np.float64), poses, key_frames, ease


def _ground_truth(data: dict, root: Path, file: Path, n_out: int, version: int) -> str | None:
    gt = data.get("ground_truth")
    if gt is None:
        return None
    gt_path = _resolve(root, gt, file, "ground_truth")
    if not gt_path.is_dir():
        raise ShotError(file, "ground_truth", f"folder {_show(gt)} does not exist", "add the folder of reference frames or remove the field")
    if version == 2:
        late = [f.name for f in ground_truth_files(gt_path) if int(f.stem) >= n_out]
        if late:
            raise ShotError(file, "ground_truth", f"{late[0]} is past the last output frame {n_out - 1}",
                            "name reference frames by output frame, 0000.png up to the last frame")
    return str(gt_path)


def load_shot(shot_dir: str | Path) -> Shot:
    """Parse and validate a shot directory (v1 or v2): counts and sizes first, then the images' pixels (once per
    file version)."""
    file, data = read_shot_json(shot_dir)
    root = file.parent
    fmt = data.get("format")
    version = FORMATS.get(fmt) if isinstance(fmt, str) else None  # a list or an object is no format either
    if version is None:
        raise ShotError(file, "format", f"is {_show(data.get('format'))}",
                        f'set "format": "{FORMAT_V2}" (or "{FORMAT}" for a two-key v1 shot)')
    paths, size = _keyframe_images(data, root, file, version)
    n = len(paths)
    skeleton = parse_skeleton(data, file)
    if version == 1:
        times, poses = _timing_v1(data, file, skeleton, size)
        key_frames, ease = (0, len(times) - 1), ("linear",)
    else:
        times, poses, key_frames, ease = _timing_v2(data, file, skeleton, size, n)
    tj = _parse_t_junctions(data, file, size, n)
    fg, occ = _parse_masks(data, root, file, size, n)
    keys = data["keyframes"]
    for k, p in enumerate(paths):  # last: decoding is the costliest check (cached per file version)
        _check_pixels(p, keys[k], file, f"keyframes[{k}]", "drawing")
    return Shot(root=str(root), keyframes=tuple(str(p) for p in paths), size=size, skeleton=skeleton, times=times,
                poses=poses, t_junctions=tj, foreground_masks=fg, occlusion_masks=occ,
                ground_truth=_ground_truth(data, root, file, len(times), version), key_frames=key_frames, ease=ease,
                version=version)


def ground_truth_files(folder: str | Path) -> list[Path]:
    """Reference frames of a ground_truth folder: 0000.png, 0001.png ... (any image extension, e.g. .jpg), in order."""
    # isdecimal, not isdigit: a file named "².png" is a digit but not a number int() reads
    return sorted((f for f in Path(folder).iterdir() if f.stem.isdecimal() and f.suffix.lower() in IMAGE_SUFFIXES),
                  key=lambda f: int(f.stem))


def output_pixels(shot: Shot) -> int:
    """Pixels of every output frame of a shot: frames x height x width (what MAX_SHOT_PIXELS bounds)."""
    return len(shot.times) * shot.size[0] * shot.size[1]


def check_batch(root: str | Path, shots: list[Shot]) -> None:
    """Refuse a batch whose shots together ask for more than MAX_BATCH_PIXELS output pixels (ShotError)."""
    total = sum(output_pixels(s) for s in shots)
    if total > MAX_BATCH_PIXELS:
        raise ShotError(root, "batch", f"{len(shots)} shots ask for {total} output pixels in all, more than "
                        f"{MAX_BATCH_PIXELS}", "split the shots into several batches (several shot roots)")
