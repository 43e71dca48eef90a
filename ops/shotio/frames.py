"""Output writers: the in-between frames and a preview video.

Frames follow docs/shot-format.md: OUT_DIR/frames/0000.png ... one 8-bit straight-
alpha RGBA PNG per output frame (optionally OUT_DIR/frames_exr/0000.exr in
half float). Every file is written atomically (temp file + rename), so a
crashed run never leaves a truncated frame behind.
"""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np

from ops.shotio.atomic import replace_into
from ops.shotio.image_io import composite_over_white, paper_under_clear, to_rgba, write_image


def write_frames(out_dir: str | Path, frames: np.ndarray, exr: bool = False) -> list[Path]:
    """frames: (T, H, W, 4) float32 straight alpha -> the written PNG paths out_dir/frames/0000.png ...

    Under full transparency every frame carries white (image_io.paper_under_clear): in the PNG where alpha
    rounds to 0, in the EXR where it is 0."""
    out_dir = Path(out_dir)
    if frames.ndim != 4 or frames.shape[3] != 4:
        raise ValueError(f"frames must be (T, H, W, 4) RGBA, got {frames.shape}")
    pngs = []
    for i in range(frames.shape[0]):  # one frame at a time: frames may be a memmap
        frame = np.asarray(frames[i], dtype=np.float32)
        pngs.append(write_image(out_dir / "frames" / f"{i:04d}.png", paper_under_clear(frame), "uint8"))
        if exr:
            clear = paper_under_clear(frame, float(np.finfo(np.float16).smallest_subnormal))  # 0 in half float
            write_image(out_dir / "frames_exr" / f"{i:04d}.exr", clear, "half")
    return pngs


def _video_frames(frames: np.ndarray, even: bool) -> list[np.ndarray]:
    """(T, H, W, 4) -> list of (H', W', 3) uint8 over white; H', W' padded to even for H.264."""
    out = []
    for i in range(frames.shape[0]):
        rgb = composite_over_white(to_rgba(np.asarray(frames[i], dtype=np.float32)))
        img = np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)
        if even:
            h, w = img.shape[:2]
            img = np.pad(img, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
        out.append(img)
    return out


def write_preview_video(path: str | Path, frames: np.ndarray, fps: float = 8) -> Path:
    """frames: (T, H, W, 4) -> animated GIF (looping) or, for a .mp4 path, H.264 video; written atomically."""
    import imageio.v2 as imageio  # imported here: only the writer needs it

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    mp4 = path.suffix.lower() == ".mp4"
    images = _video_frames(frames, even=mp4)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    os.close(fd)
    try:
        if mp4:
            imageio.mimwrite(tmp, images, format="FFMPEG", fps=fps, macro_block_size=1)
        else:
            # Pillow merges identical consecutive frames (summing their durations), so a
            # static stretch plays for the right time but counts as one GIF frame.
            imageio.mimwrite(tmp, images, format="GIF", duration=1000.0 / fps, loop=0)
        replace_into(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


EXPORTS = ("gif", "mp4", "oca", "mov")  # besides the PNG frames (always): what write_outputs can write
DEFAULT_EXPORTS = ("gif", "oca")  # cheap (a preview; the OCA folder is hard links); the videos on request
ENCODED = {"gif": "preview.gif", "mp4": "preview.mp4", "mov": "alpha.mov"}  # exports encoded from the frames
# (the OCA links the written PNGs instead): their names in OUT_DIR


def _check_exports(exports: tuple[str, ...]) -> None:
    unknown = set(exports) - set(EXPORTS)
    if unknown:
        raise ValueError(f"unknown exports {sorted(unknown)}: use some of {EXPORTS}")


def _encode(kind: str, path: Path, frames: np.ndarray, fps: float) -> None:
    """One encoded export (ENCODED) of frames (T, H, W, 4) at `path`, written atomically."""
    from ops.shotio.exports import write_alpha_video

    if kind == "mov":
        write_alpha_video(path, frames, fps)
    else:
        write_preview_video(path, frames, fps)


def stage_outputs(folder: str | Path, frames: np.ndarray, exports: tuple[str, ...] = ("gif",),
                  fps: float = 12.0) -> Path:
    """What write_outputs writes from the frames (T, H, W, 4) alone, the PNG frames and the encoded exports, written
    ahead under `folder` (a hidden folder inside OUT_DIR, so that a rename puts them in place) in OUT_DIR's layout,
    for write_outputs(staged=folder) to move into place once the run is known to have succeeded. -> folder."""
    _check_exports(exports)
    folder = Path(folder)
    write_frames(folder, frames)
    for kind in exports:
        if kind in ENCODED:
            _encode(kind, folder / ENCODED[kind], frames, fps)
    return folder


def written_version(out_dir: str | Path) -> str | None:
    """The `frames_version` OUT_DIR's report.json names (the frames written there), or None."""
    try:
        version = json.loads((Path(out_dir) / "report.json").read_text()).get("frames_version")
    except (OSError, ValueError, AttributeError):
        return None
    return version if isinstance(version, str) else None


def write_outputs(out_dir: Path, frames: np.ndarray, report: dict, exports: tuple[str, ...] = ("gif",),
                  fps: float = 12.0, staged: Path | None = None) -> None:
    """OUT_DIR/frames/*.png, report.json and the asked exports (docs/shot-format.md); frames (T, H, W, 4)
    straight alpha, one per output frame (frame i = OUT_DIR/frames/000i.png). Exports: preview.gif and
    preview.mp4 (over white), OUT_DIR/oca/<shot>.oca (Open Cel Animation, keys marked) and alpha.mov (ProRes
    4444 with alpha); report["key_frames"] marks the keys, report["partition"] names the OCA document.

    When OUT_DIR already holds exactly these frames (report.json names the same `frames_version` and every
    file is there), they are not written again; frames left over from a longer earlier run are removed.
    staged: a folder where stage_outputs wrote these frames ahead: its files are renamed into place instead of
    written (one it lacks is written here).
    """
    from ops.shotio.exports import write_oca

    _check_exports(exports)
    out_dir.mkdir(parents=True, exist_ok=True)
    name = str(report.get("partition") or out_dir.name)
    pngs = [out_dir / "frames" / f"{i:04d}.png" for i in range(len(frames))]
    files = {**{kind: out_dir / file for kind, file in ENCODED.items()}, "oca": out_dir / "oca" / f"{name}.oca"}
    previous = written_version(out_dir)
    same = previous is not None and previous == report.get("frames_version")
    if not (same and all(p.is_file() for p in pngs)):
        if staged is not None and all((staged / "frames" / p.name).is_file() for p in pngs):
            pngs[0].parent.mkdir(parents=True, exist_ok=True)
            for p in pngs:
                replace_into(staged / "frames" / p.name, p)
        else:
            write_frames(out_dir, frames)
        same = False
    for kind in exports:
        if same and files[kind].is_file():
            continue
        if kind == "oca":
            keys = tuple(report.get("key_frames") or (0, len(frames) - 1))
            write_oca(out_dir / "oca", name, pngs, keys, frames.shape[1:3], fps)
        elif staged is not None and (staged / ENCODED[kind]).is_file():
            replace_into(staged / ENCODED[kind], files[kind])
        else:
            _encode(kind, files[kind], frames, fps)
    for extra in (out_dir / "frames").glob("[0-9][0-9][0-9][0-9].png"):
        if int(extra.stem) >= len(frames):
            extra.unlink()
    write_report(out_dir, report)


def write_report(out_dir: Path, report: dict) -> None:
    """OUT_DIR/report.json, atomically."""
    tmp = out_dir / f".report.json.tmp{os.getpid()}"
    tmp.write_text(json.dumps(report, indent=2))
    os.replace(tmp, out_dir / "report.json")
