"""A small valid shot written from code, and the corruptions the hardening tests apply to it.

The shot is 64 x 64 px (above MIN_SIDE), six joints, two poses plus `frames`, a T-junction, and
manual masks for keyframe 0 so that every field of docs/shot-format.md can be mutated.
"""
from __future__ import annotations

import copy
import json
import math
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
from PIL import Image

from ops.shotio.image_io import read_image, to_rgba, write_image

SIZE = 64
JOINTS = ["hips", "spine", "neck", "r_shoulder", "r_elbow", "r_hand"]
PARENTS = [-1, 0, 1, 1, 3, 4]


def _pose(angle: float) -> list:
    """A chain with the arm rotated by `angle` about the shoulder (pixels of a 64 px image)."""
    pts = [[32.0, 52.0, 0.0], [32.0, 36.0, 0.0], [32.0, 24.0, 0.0], [36.0, 26.0, 0.0]]
    for r in (8.0, 16.0):
        pts.append([36.0 + r * math.cos(angle), 26.0 + r * math.sin(angle), -1.0])
    return pts


def drawing() -> np.ndarray:
    """(64, 64, 3) float32: a dark stick figure on white paper."""
    img = np.ones((SIZE, SIZE, 3), np.float32)
    cv2.line(img, (32, 52), (32, 20), (0.1, 0.1, 0.1), 3)
    cv2.line(img, (36, 26), (50, 34), (0.1, 0.1, 0.1), 3)
    return img


def shot_json() -> dict:
    return {
        "format": "inbetween-shot/1",
        "keyframes": ["key0.png", "key1.png"],
        "skeleton": {"joints": list(JOINTS), "parents": list(PARENTS)},
        "poses": [{"t": 0.0, "joints": _pose(0.5)}, {"t": 1.0, "joints": _pose(1.2)}],
        "frames": 5,
        "t_junctions": [[[33.0, 30.0]], []],
        "masks": {"foreground": ["key0_fg.png", None], "occlusion": [["key0_occ0.png"], []]},
    }


def write_shot(d: Path, data: dict | None = None) -> Path:
    """Write the valid shot (or `data` as its shot.json) into directory d."""
    d.mkdir(parents=True, exist_ok=True)
    img = drawing()
    write_image(d / "key0.png", img)
    write_image(d / "key1.png", img)
    fg = (img[..., 0] < 0.5).astype(np.float32)
    fg = cv2.dilate(fg, np.ones((5, 5), np.uint8))
    write_image(d / "key0_fg.png", fg)
    occ = np.zeros_like(fg)
    occ[24:34, 30:40] = 1.0
    write_image(d / "key0_occ0.png", occ * fg)
    (d / "shot.json").write_text(json.dumps(data if data is not None else shot_json()))
    return d


# ---------------------------------------------------------------- image corruptions


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def huge_png(width: int = 100_000, height: int = 100_000) -> bytes:
    """A tiny PNG file whose header claims width x height pixels (a decompression bomb's header)."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    idat = zlib.compress(b"\x00" * 64)
    return b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr) + _png_chunk(b"IDAT", idat) + _png_chunk(b"IEND", b"")


def _pil(img: np.ndarray) -> Image.Image:
    return Image.fromarray((np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8))


CORRUPTIONS = ("truncated", "header_only", "zero_size", "random_bytes", "png16", "grey16", "palette", "grey",
               "grey_alpha", "cmyk_jpeg", "huge_dimensions", "blank_white", "transparent", "tiny", "nan_exr",
               "other_size", "text_file", "directory")


def corrupt_image(shot: Path, rel: str, kind: str, frac: float = 0.5) -> str:
    """Replace image `rel` of the shot by a corrupted one; returns its new relative path (the format may change)."""
    path = shot / rel
    src = path.read_bytes() if path.is_file() else b""
    try:  # re-encodings keep the picture: the drawing itself when it reads, else the synthetic one
        img = to_rgba(read_image(path))[..., :3]
    except Exception:
        img = drawing()
    stem = Path(rel).stem
    if kind == "truncated":
        path.write_bytes(src[: max(1, int(len(src) * frac))])
    elif kind == "header_only":
        path.write_bytes(src[:33])
    elif kind == "zero_size":
        path.write_bytes(b"")
    elif kind == "random_bytes":
        path.write_bytes(b"\x89PNG\r\n\x1a\n" + np.random.default_rng(int(frac * 1000)).bytes(300))
    elif kind == "png16":
        cv2.imwrite(str(path), (img * 65535).astype(np.uint16))
    elif kind == "grey16":
        cv2.imwrite(str(path), (img[..., 0] * 65535).astype(np.uint16))
    elif kind == "palette":
        _pil(img).convert("P").save(path)
    elif kind == "grey":
        _pil(img).convert("L").save(path)
    elif kind == "grey_alpha":
        _pil(img).convert("LA").save(path)
    elif kind == "cmyk_jpeg":
        path.unlink(missing_ok=True)
        rel = f"{stem}.jpg"
        _pil(img).convert("CMYK").save(shot / rel, quality=95)
    elif kind == "huge_dimensions":
        path.write_bytes(huge_png())
    elif kind == "blank_white":
        _pil(np.ones_like(img)).save(path)
    elif kind == "transparent":
        Image.fromarray(np.zeros(img.shape[:2] + (4,), np.uint8)).save(path)
    elif kind == "tiny":
        _pil(img[:8, :8]).save(path)
    elif kind == "nan_exr":
        path.unlink(missing_ok=True)
        rel = f"{stem}.exr"
        bad = img.copy()
        bad[bad.shape[0] // 2, bad.shape[1] // 2] = np.nan  # the image may already be a tiny one
        write_image(shot / rel, bad, dtype="float")
    elif kind == "other_size":
        _pil(np.full((img.shape[0] + 16, img.shape[1], 3), 0.5, np.float32)).save(path)
    elif kind == "text_file":
        path.write_text("not an image\n")
    elif kind == "directory":
        path.unlink(missing_ok=True)
        path.mkdir()
    else:
        raise ValueError(kind)
    return rel


def with_image(data: dict, old: str, new: str) -> dict:
    """shot.json `data` with every reference to image `old` renamed to `new`."""
    text = json.dumps(copy.deepcopy(data))
    return json.loads(text.replace(json.dumps(old), json.dumps(new)))
