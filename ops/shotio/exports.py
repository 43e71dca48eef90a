"""Output for animation software: an Open Cel Animation (OCA) folder and a video with alpha.

OCA (the RxLaboratory's open format, version 1.1.0, which Krita, OpenToonz/Tahoma2D and After Effects import)
is one JSON document plus a folder of PNG frames. Ours has two paint layers at the document's size: `inbetween`
(every output frame, frameNumber = the output frame) and `keys`, a reference layer (shown in the timeline,
never rendered) holding each keyframe from its frame until the next key: the keys marked where an animator
looks for them. Each key's frame object also carries `meta.inbetween.key` (its index).

The alpha video is Apple ProRes 4444 (prores_ks, profile 4444, 10-bit YUVA) in a .mov, through the ffmpeg that
imageio-ffmpeg ships: compositors read its alpha channel, where the MP4/GIF previews are over white.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from ops.shotio.image_io import paper_under_clear, write_image

OCA_VERSION = "1.1.0"


def _frame_object(name: str, file: str, number: int, duration: int, size: tuple[int, int], meta: dict | None) -> dict:
    h, w = size
    out = {"name": name, "fileName": file, "frameNumber": int(number), "duration": int(duration), "opacity": 1.0,
           "position": [w // 2, h // 2], "width": w, "height": h}
    if meta:
        out["meta"] = meta
    return out


def _layer_object(name: str, frames: list[dict], size: tuple[int, int], reference: bool, label: int) -> dict:
    h, w = size
    return {"name": name, "frames": frames, "childLayers": [], "type": "paintlayer", "fileType": "png",
            "blendingMode": "normal", "animated": len(frames) > 1, "position": [w // 2, h // 2], "width": w,
            "height": h, "label": label, "opacity": 1.0, "visible": True, "passThrough": False,
            "reference": reference, "inheritAlpha": False}


def write_oca(out_dir: str | Path, name: str, frame_pngs: list[Path], key_frames: tuple[int, ...],
              size: tuple[int, int], fps: float) -> Path:
    """OUT/name.oca and OUT/name/{inbetween,keys}/*.png from the written frame PNGs (one per output frame,
    straight-alpha RGBA, copied or hard-linked); returns the .oca path. Replaces an earlier export of the same
    name atomically (a temporary folder renamed into place)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=out_dir, prefix=".oca-"))
    try:
        inbetween, keys = [], []
        for i, png in enumerate(frame_pngs):
            rel = f"{name}/inbetween/inbetween_{i:05d}.png"
            _link(png, tmp / rel)
            k = key_frames.index(i) if i in key_frames else None
            inbetween.append(_frame_object(f"inbetween_{i:05d}", rel, i, 1, size,
                                           {"inbetween": {"key": k}} if k is not None else None))
        for k, f in enumerate(key_frames):
            end = key_frames[k + 1] if k + 1 < len(key_frames) else len(frame_pngs)
            rel = f"{name}/keys/keys_{f:05d}.png"
            _link(frame_pngs[f], tmp / rel)
            keys.append(_frame_object(f"keys_{f:05d}", rel, f, end - f, size, {"inbetween": {"key": k}}))
        h, w = size
        doc = {"name": name, "frameRate": float(fps), "width": w, "height": h, "startTime": 0,
               "endTime": len(frame_pngs) - 1, "colorDepth": "U8", "backgroundColor": [1.0, 1.0, 1.0, 0.0],
               "layers": [_layer_object("keys", keys, size, reference=True, label=1),
                          _layer_object("inbetween", inbetween, size, reference=False, label=0)],
               "originApp": "inbetween", "originAppVersion": "0.1.0", "ocaVersion": OCA_VERSION}
        (tmp / f"{name}.oca").write_text(json.dumps(doc, indent=2))
        for item in (f"{name}.oca", name):  # the document and its folder, each replaced whole
            target = out_dir / item
            if target.is_dir():
                shutil.rmtree(target)
            os.replace(tmp / item, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out_dir / f"{name}.oca"


def _link(src: Path, dst: Path) -> None:
    """dst as a hard link to src where the file system allows, else a copy."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.link(src, dst)
    except OSError:
        shutil.copyfile(src, dst)


def write_alpha_video(path: str | Path, frames: np.ndarray, fps: float) -> Path:
    """frames (T, H, W, 4) straight-alpha RGBA -> a ProRes 4444 .mov with alpha (even size: padded by one
    transparent pixel where odd); written atomically."""
    import imageio_ffmpeg  # the ffmpeg binary imageio-ffmpeg ships: nothing downloaded

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(dir=path.parent, prefix=".mov-"))
    try:
        t, h, w = frames.shape[:3]
        for i in range(t):
            rgba = np.pad(np.asarray(frames[i], np.float32), ((0, h % 2), (0, w % 2), (0, 0)))
            rgba = paper_under_clear(rgba)
            write_image(work / f"{i:05d}.png", rgba, "uint8")
        tmp = work / f"out{path.suffix}"
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-y", "-framerate", str(fps),
               "-i", str(work / "%05d.png"), "-c:v", "prores_ks", "-profile:v", "4444", "-pix_fmt", "yuva444p10le",
               "-vendor", "apl0", str(tmp)]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"ffmpeg could not write {path.name}: {' '.join(done.stderr.split())[:200]}")
        os.replace(tmp, path)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return path
