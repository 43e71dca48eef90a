"""Image reading and writing through OpenImageIO, with unassociated alpha.

Images in memory are float32 in [0, 1], shape (H, W, C) with C in {1, 3, 4};
straight (unassociated) alpha, so a PNG round trip is exact.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from ops.errors import ShotError

MAX_SIDE = 8192  # refuse larger images before decoding their pixels


def image_size(path: str | Path, field: str = "image") -> tuple[int, int]:
    """(height, width) read from the header only; raises ShotError if unreadable."""
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise ShotError(path, field, f"cannot read image ({oiio.geterror().strip() or 'unknown format'})",
                        "give a PNG/JPEG/TIFF/EXR file that exists")
    spec = inp.spec()
    inp.close()
    return spec.height, spec.width


def read_image(path: str | Path, field: str = "image", max_side: int = MAX_SIDE) -> np.ndarray:
    """Read an image as float32 (H, W, C) in [0, 1], straight alpha; checks the size first."""
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(str(path), config)
    if inp is None:
        raise ShotError(path, field, f"cannot read image ({oiio.geterror().strip() or 'unknown format'})",
                        "give a PNG/JPEG/TIFF/EXR file that exists")
    spec = inp.spec()
    if spec.width > max_side or spec.height > max_side:
        inp.close()
        raise ShotError(path, field, f"image is {spec.width}x{spec.height}, larger than {max_side}x{max_side}",
                        f"downscale the drawing to at most {max_side} px per side")
    pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
    inp.close()
    if pixels is None:
        raise ShotError(path, field, "cannot decode pixels", "re-export the image")
    return np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)


def to_rgba(image: np.ndarray) -> np.ndarray:
    """Any (H, W[, C]) image -> float32 (H, W, 4) straight-alpha RGBA."""
    img = np.asarray(image, dtype=np.float32)
    if img.ndim == 2:
        img = img[..., None]
    c = img.shape[2]
    if c == 1:
        return np.concatenate([np.repeat(img, 3, 2), np.ones_like(img)], 2)
    if c == 2:  # grey + alpha
        return np.concatenate([np.repeat(img[..., :1], 3, 2), img[..., 1:2]], 2)
    if c == 3:
        return np.concatenate([img, np.ones_like(img[..., :1])], 2)
    return img[..., :4].copy()


def composite_over_white(rgba: np.ndarray) -> np.ndarray:
    """(H, W, 4) straight alpha -> (H, W, 3) over a white page."""
    a = rgba[..., 3:4]
    return rgba[..., :3] * a + (1.0 - a)


def write_image(path: str | Path, image: np.ndarray, dtype: str = "uint8") -> Path:
    """Write atomically (temp file + rename); dtype 'uint8' (PNG) or 'half'/'float' (EXR)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    img = np.ascontiguousarray(np.clip(image, 0.0, 1.0) if dtype == "uint8" else image, dtype=np.float32)
    if img.ndim == 2:
        img = img[..., None]
    h, w, c = img.shape
    fmt = {"uint8": oiio.UINT8, "half": oiio.HALF, "float": oiio.FLOAT}[dtype]
    spec = oiio.ImageSpec(w, h, c, fmt)
    spec.attribute("oiio:UnassociatedAlpha", 1)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    os.close(fd)
    try:
        out = oiio.ImageOutput.create(tmp)
        if out is None or not out.open(tmp, spec):
            raise OSError(f"{path}: cannot write image: {oiio.geterror()}")
        out.write_image(img)
        out.close()
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
