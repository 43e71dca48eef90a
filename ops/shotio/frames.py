"""Output writers: the in-between frames and a preview video.

Frames follow SHOT_FORMAT.md: OUT_DIR/frames/0000.png ... one 8-bit straight-
alpha RGBA PNG per output time (optionally OUT_DIR/frames_exr/0000.exr in
half float). Every file is written atomically (temp file + rename), so a
crashed run never leaves a truncated frame behind.
"""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np

from ops.shotio.image_io import composite_over_white, to_rgba, write_image


def write_frames(out_dir: str | Path, frames: np.ndarray, exr: bool = False) -> list[Path]:
    """frames: (T, H, W, 4) float32 straight alpha -> the written PNG paths out_dir/frames/0000.png ..."""
    out_dir = Path(out_dir)
    if frames.ndim != 4 or frames.shape[3] != 4:
        raise ValueError(f"frames must be (T, H, W, 4) RGBA, got {frames.shape}")
    pngs = []
    for i in range(frames.shape[0]):  # one frame at a time: frames may be a memmap
        frame = np.asarray(frames[i], dtype=np.float32)
        pngs.append(write_image(out_dir / "frames" / f"{i:04d}.png", frame, "uint8"))
        if exr:
            write_image(out_dir / "frames_exr" / f"{i:04d}.exr", frame, "half")
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
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def write_outputs(out_dir: Path, frames: np.ndarray, report: dict) -> None:
    """OUT_DIR/frames/*.png, preview.gif and report.json (SHOT_FORMAT.md); frames (T, H, W, 4) straight alpha.

    When OUT_DIR already holds exactly these frames (report.json names the same `frames_version` and every
    PNG is there), they are not written again; frames left over from a longer earlier run are removed.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    pngs = [out_dir / "frames" / f"{i:04d}.png" for i in range(len(frames))]
    try:
        previous = json.loads((out_dir / "report.json").read_text()).get("frames_version")
    except (OSError, ValueError):
        previous = None
    same = previous is not None and previous == report.get("frames_version")
    if not (same and all(p.is_file() for p in pngs) and (out_dir / "preview.gif").is_file()):
        write_frames(out_dir, frames)
        write_preview_video(out_dir / "preview.gif", frames)
    for extra in (out_dir / "frames").glob("[0-9][0-9][0-9][0-9].png"):
        if int(extra.stem) >= len(frames):
            extra.unlink()
    tmp = out_dir / f".report.json.tmp{os.getpid()}"
    tmp.write_text(json.dumps(report, indent=2))
    os.replace(tmp, out_dir / "report.json")
