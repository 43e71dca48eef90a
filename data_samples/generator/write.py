"""Write a shot directory: shot.json, keyframes, ground-truth frames, foreground and occlusion ground truth."""
from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import cv2
import numpy as np

from .drawing import Drawing, Look, draw, make_look
from .legacy import render_with_union
from .occlusion import Occlusion, occlusion_pairs
from .poses import interpolate_pose, quantize
from .shots import NEW_SHOTS, SHOTS, ShotSpec

FORMAT = "inbetween-shot/1"
FRAMES = 9  # output frames per shot, both keyframes included


def output_poses(spec: ShotSpec) -> tuple[np.ndarray, np.ndarray]:
    """(T,) times and (T, J, 3) poses at the FRAMES evenly spaced output times, keys quantized first."""
    k0, k1 = quantize(spec.keys[0]), quantize(spec.keys[1])
    times = np.arange(FRAMES) / (FRAMES - 1)
    poses = [k0] + [interpolate_pose(k0, k1, float(t), spec.char.parents) for t in times[1:-1]] + [k1]
    if not spec.two_poses_only:  # written to JSON: draw exactly the rounded values
        poses = [quantize(p) for p in poses]
    return times, np.stack(poses)


def shot_look(spec: ShotSpec) -> Look | None:
    """The shot's fixed look (paper, camera), or None for the original ink renderer."""
    return None if spec.style is None else make_look(spec.style, spec.palette, spec.size, spec.char.seed)


def shot_drawing(spec: ShotSpec, pose: np.ndarray, look: Look | None) -> Drawing:
    """The shot's character drawn in one pose (J, 3)."""
    if look is None:
        return Drawing(*render_with_union(spec.char, pose, spec.size))
    return draw(spec.char, pose, spec.size, look)


def _write_png(path: Path, img: np.ndarray) -> None:
    """Write an 8-bit grey (H, W) or RGB (H, W, 3) PNG (OpenCV wants BGR)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    data = img if img.ndim == 2 else img[..., ::-1]
    if not cv2.imwrite(str(path), np.ascontiguousarray(data), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise OSError(f"{path}: cannot write PNG")


def _write_drawing(path: Path, drawing: Drawing) -> None:
    """Write a drawing as its JPEG bytes (photographed styles; path ends in .jpg) or as a PNG."""
    if drawing.jpeg is None:
        _write_png(path, drawing.rgb)
    else:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(drawing.jpeg)


def _mask_png(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool -> uint8 white = region."""
    return np.where(mask, 255, 0).astype(np.uint8)


def _coverage_png(cov: np.ndarray) -> np.ndarray:
    """(H, W) float coverage in [0, 1] -> uint8 0-255."""
    return np.round(np.clip(cov, 0, 1) * 255).astype(np.uint8)


def _points(pts: np.ndarray) -> list:
    """(k, 2) px -> JSON list rounded to 0.1 px."""
    return [[round(float(x), 1), round(float(y), 1)] for x, y in pts]


def _pose_json(pose: np.ndarray) -> list:
    """(J, 3) -> JSON list of [x, y, z] with the quantized values."""
    return [[float(v) for v in row] for row in quantize(pose)]


def pair_record(spec: ShotSpec, o: Occlusion, k: int, pose: np.ndarray, file: str) -> dict:
    """One gt_occ/pairs.json entry: which part covers which, their bones and depths, the T-junctions."""
    bones = spec.char.bones
    depth = lambda b: round(float(0.5 * (pose[bones[b][0], 2] + pose[bones[b][1], 2])), 4)  # noqa: E731
    return {"file": file, "keyframe": k, "front_part": spec.char.part_name(o.front),
            "back_part": spec.char.part_name(o.back), "front_bone": o.front, "back_bone": o.back,
            "front_joints": list(bones[o.front]), "back_joints": list(bones[o.back]),
            "front_depth": depth(o.front), "back_depth": depth(o.back), "adjacent": o.adjacent,
            "joined": o.joined,
            "pixels": int(o.mask.sum()), "t_junctions": _points(o.junctions)}


def write_shot(spec: ShotSpec, out_root: Path) -> Path:
    """Render and write one shot directory under out_root; returns its path (replaced if present)."""
    d = out_root / spec.name
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    times, poses = output_poses(spec)
    look = shot_look(spec)
    frames = [shot_drawing(spec, p, look) for p in poses]
    ext = ".png" if frames[0].jpeg is None else ".jpg"
    for i, f in enumerate(frames):
        _write_drawing(d / "gt" / f"{i:04d}{ext}", f)
    _write_drawing(d / f"key0{ext}", frames[0])
    _write_drawing(d / f"key1{ext}", frames[-1])

    keys = [(poses[0], frames[0]), (poses[-1], frames[-1])]
    pairs = [occlusion_pairs(spec.char, pose, f.coverage) for pose, f in keys]
    junctions, index = [], []  # the original definition: non-adjacent pairs only
    for k in range(2):
        pts = []
        for i, o in enumerate(o for o in pairs[k] if not o.adjacent):
            _write_png(d / "gt_occ" / f"key{k}_occ{i}.png", _mask_png(o.mask))
            index.append({"file": f"key{k}_occ{i}.png", "keyframe": k, "front_bone": o.front, "back_bone": o.back,
                          "front_joints": list(spec.char.bones[o.front]), "back_joints": list(spec.char.bones[o.back]),
                          "t_junctions": _points(o.junctions)})
            pts += _points(o.junctions)
        junctions.append(pts)
    (d / "gt_occ").mkdir(exist_ok=True)
    (d / "gt_occ" / "index.json").write_text(json.dumps(index, indent=1) + "\n")
    write_ground_truth(spec, d, keys, pairs)

    data: dict = {"format": FORMAT, "keyframes": [f"key0{ext}", f"key1{ext}"],
                  "skeleton": {"joints": spec.char.joints, "parents": spec.char.parents}}
    given = [0, len(times) - 1] if spec.two_poses_only else range(len(times))
    data["poses"] = [{"t": float(times[i]), "joints": _pose_json(poses[i])} for i in given]
    if spec.two_poses_only:
        data["frames"] = FRAMES
    data["t_junctions"] = junctions
    if spec.manual_masks:
        fg = np.max(np.stack(frames[0].coverage), axis=0) > 0.5
        _write_png(d / "key0_fg.png", _mask_png(fg))
        occ_files = []
        for i, o in enumerate(o for o in pairs[0] if not o.adjacent):
            _write_png(d / f"key0_occ{i}.png", _mask_png(o.mask))
            occ_files.append(f"key0_occ{i}.png")
        data["masks"] = {"foreground": ["key0_fg.png", None], "occlusion": [occ_files, []]}
    data["ground_truth"] = "gt"
    (d / "shot.json").write_text(_dump(data) + "\n")
    return d


def write_ground_truth(spec: ShotSpec, d: Path, keys: list[tuple[np.ndarray, Drawing]],
                       pairs: list[list[Occlusion]]) -> None:
    """gt_fg/key{k}.png (coverage), gt_occ/key{k}_pair{i}.png + pairs.json (issue 15: every overlapping pair
    of parts, adjacent ones included) and gt_occ/key{k}_union.png."""
    records = []
    for k, ((pose, drawing), occ) in enumerate(zip(keys, pairs)):
        _write_png(d / "gt_fg" / f"key{k}.png", _coverage_png(drawing.union))
        union = np.zeros(spec.size, bool)
        for i, o in enumerate(occ):
            name = f"key{k}_pair{i}.png"
            _write_png(d / "gt_occ" / name, _mask_png(o.mask))
            records.append(pair_record(spec, o, k, pose, name))
            union |= o.mask
        _write_png(d / "gt_occ" / f"key{k}_union.png", _mask_png(union))
    (d / "gt_occ" / "pairs.json").write_text(json.dumps(records, indent=1) + "\n")


def _dump(data: dict) -> str:
    """JSON with every innermost list (names, parents, [x, y, z]) on one line: readable and diff-friendly."""
    text = json.dumps(data, indent=1)
    return re.sub(r"\[[^\[\]{}]*\]", lambda m: "[" + ", ".join(v.strip() for v in m.group(0)[1:-1].split(",")) + "]"
                  if m.group(0)[1:-1].strip() else "[]", text)


def generate(out_root: Path, names: list[str] | None = None) -> list[Path]:
    """Write the named shots (default: all) under out_root; returns their directories."""
    return [write_shot(SHOTS[n](), out_root) for n in (names or list(SHOTS))]


def contact_sheet(root: Path, names: list[str] | None = None, tile: int = 128) -> Path | None:
    """previews/new_shots.png under root: key0 | key1 of each shot (default the six of issue 8), `tile` px each,
    two shots a row, names written on the tiles; None when a shot is missing."""
    names = names or NEW_SHOTS
    tiles = []
    for n in names:
        d = root / n
        if not (d / "shot.json").is_file():
            return None
        keys = json.loads((d / "shot.json").read_text())["keyframes"]
        for k, key in enumerate(keys):
            img = cv2.imread(str(d / key), cv2.IMREAD_COLOR)
            img = cv2.resize(img, (tile, tile), interpolation=cv2.INTER_AREA)
            cv2.putText(img, f"{n} {k}", (3, 11), cv2.FONT_HERSHEY_PLAIN, 0.8, (40, 40, 200), 1, cv2.LINE_AA)
            tiles.append(img)
    rows = [np.hstack(tiles[i:i + 4]) for i in range(0, len(tiles), 4)]
    if len(rows) > 1 and rows[-1].shape != rows[0].shape:
        rows[-1] = np.hstack([rows[-1], np.full((tile, rows[0].shape[1] - rows[-1].shape[1], 3), 255, np.uint8)])
    path = root / "previews" / "new_shots.png"
    path.parent.mkdir(exist_ok=True)
    cv2.imwrite(str(path), np.vstack(rows), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return path
