"""Saving a shot from the editor: validate a candidate shot.json exactly as the CLI would, then write atomically.

Validation runs `load_shot` on a scratch directory holding the candidate shot.json, the files it names
(hard links into the real shot, or copies) and the staged mask uploads, so nothing in the real shot
directory changes when it fails. Errors are the CLI's one-line ShotError, with the scratch path mapped
back to the real shot.json.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

from ops.errors import ShotError
from ops.shotio.atomic import replace_into
from ops.shotio.load import FORMAT_V2, load_shot
from ops.types import Shot

BACKUP = "shot.json.bak"


def keyframe_names(data: dict) -> list[str]:
    """The keyframe paths a shot.json object names (malformed entries skipped)."""
    keys = data.get("keyframes")
    return [n for n in keys if isinstance(n, str)] if isinstance(keys, list) else []


def referenced_files(data: dict) -> list[str]:
    """Relative paths a shot.json object names (keyframes, manual masks); malformed entries are skipped."""
    names: list = keyframe_names(data)
    masks = data.get("masks") if isinstance(data.get("masks"), dict) else {}
    fg = masks.get("foreground") if isinstance(masks.get("foreground"), list) else []
    names += fg
    for per_key in masks.get("occlusion") if isinstance(masks.get("occlusion"), list) else []:
        names += per_key if isinstance(per_key, list) else []
    return [n for n in names if isinstance(n, str) and n]


def _inside(root: Path, rel: str) -> Path | None:
    """root / rel when it stays inside root (load_shot reports the ones that escape), else None."""
    p = (root / rel).resolve()
    return p if p.is_relative_to(root) and not Path(rel).is_absolute() else None


def _mirror(src: Path, dst: Path) -> None:
    """Hard-link src to dst (copy across file systems); directories are mirrored file by file."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    if src.is_dir():
        shutil.copytree(src, dst, copy_function=_link_or_copy, dirs_exist_ok=True)
    else:
        _link_or_copy(src, dst)


def _link_or_copy(src, dst) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def key_pose_indices(data) -> list[int]:
    """Index into data["poses"] of each keyframe's pose: v1 the first and the last pose; v2 the pose at each key
    frame (`key_frames`, [0] when a one-drawing shot leaves it out). Keys whose pose cannot be found are left out."""
    poses = data.get("poses") if isinstance(data, dict) else None
    if not isinstance(poses, list) or not poses:
        return []
    key_frames = data.get("key_frames")
    if not isinstance(key_frames, list) and data.get("format") == FORMAT_V2:
        key_frames = [0]  # a one-drawing v2 shot may leave key_frames out
    if not isinstance(key_frames, list):
        return [0, len(poses) - 1] if len(poses) >= 2 else [0]
    frames = [p.get("frame") if isinstance(p, dict) else None for p in poses]
    return [frames.index(f) for f in key_frames if f in frames]


def validate(shot_dir: Path, data, staged: dict[str, bytes], scratch_root: Path,
             check: Callable[[Shot, dict, Path], None] | None = None, new_files: dict[str, bytes] | None = None) -> Shot:
    """Load the candidate shot.json `data` as the CLI would, with staged masks {relative name: PNG bytes}, then
    run `check(shot, data, file)` (the editor's own checks, editor/jointcheck.py) while the scratch copy exists.
    `new_files` {relative name: bytes} are files the save would add (an uploaded keyframe), placed in the copy.

    Raises ShotError naming the real shot.json. Nothing under shot_dir is written.
    """
    shot_dir = Path(shot_dir).resolve()
    file = shot_dir / "shot.json"
    if not isinstance(data, dict):
        raise ShotError(file, "shot.json", "top level is not an object", "send the whole shot.json object")
    scratch_root.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(dir=scratch_root, prefix="validate-")).resolve()
    try:
        keyframes = set(keyframe_names(data))
        for rel in referenced_files(data) + ([data["ground_truth"]] if isinstance(data.get("ground_truth"), str) else []):
            src = _inside(shot_dir, rel)
            if rel in staged and rel not in keyframes:  # an upload never stands in for a drawing
                target = _inside(scratch, rel)
                if target is not None:
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_bytes(staged[rel])
            elif src is not None and src.exists():
                _mirror(src, scratch / src.relative_to(shot_dir))
        for rel, content in (new_files or {}).items():
            target = _inside(scratch, rel)
            if target is not None:
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(content)
        (scratch / "shot.json").write_text(json.dumps(data))
        try:
            shot = load_shot(scratch)
            if check is not None:
                check(shot, data, scratch / "shot.json")
        except ShotError as e:
            raise ShotError(_real_path(e.file, scratch, shot_dir), e.field, e.problem, e.fix) from None
        return shot
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _real_path(path: str, scratch: Path, shot_dir: Path) -> str:
    """A path inside the scratch copy, named as the file it stands for in the real shot."""
    p = Path(path)
    return str(shot_dir / p.relative_to(scratch)) if p.is_relative_to(scratch) else path


def write_atomic(path: Path, data: bytes) -> None:
    """Write bytes to path through a temporary sibling, flushed to disk, then renamed into place."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        replace_into(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def save(shot_dir: Path, data: dict, staged: dict[str, bytes]) -> list[str]:
    """Write the staged masks that `data` names, then shot.json (the previous one kept as shot.json.bak).

    Masks go first, so the new shot.json never names a mask that is not yet on disk. Returns the masks written.
    """
    shot_dir = Path(shot_dir).resolve()
    named = set(referenced_files(data)) - set(keyframe_names(data))
    written = sorted(n for n in staged if n in named)
    for name in written:
        write_atomic(shot_dir / name, staged[name])
    file = shot_dir / "shot.json"
    if file.exists():
        write_atomic(shot_dir / BACKUP, file.read_bytes())
    write_atomic(file, (json.dumps(data, indent=1) + "\n").encode())
    return written
