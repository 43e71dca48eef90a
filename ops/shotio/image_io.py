"""Image reading and writing through OpenImageIO, with unassociated alpha.

Images in memory are float32 in [0, 1], shape (H, W, C) with C in {1, 3, 4};
straight (unassociated) alpha, so a PNG round trip is exact.

Reading is defensive: a file is refused, with one ShotError line, before its
pixels are decoded when its header is unreadable, has no pixels or claims more
than MAX_SIDE per side (a decompression bomb), and after decoding when the
decoder reports damage (a truncated PNG or JPEG). What the C decoders print
(libpng's "libpng error: ...") is captured into that line instead of the
terminal. `pixel_problem` adds the checks of a drawing's content (finite
values, not a blank page), cached per file version.
"""
from __future__ import annotations

import functools
import os
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from ops.errors import ShotError
from ops.shotio.atomic import replace_into

MAX_SIDE = 8192  # refuse larger images before decoding their pixels
MIN_SIDE = 32  # a smaller drawing has too few pixels to mesh a character
MAX_CHANNELS = 16  # RGBA plus a few extra channels (TIFF, EXR); more is not a drawing
BLANK_RANGE = 1.0 / 255.0  # a drawing whose colours all lie within this of each other is a blank page
READ_FIX = "give a PNG/JPEG/TIFF/EXR file that exists"


def _one_line(text: str, limit: int = 240) -> str:
    """Collapse a decoder's (possibly multi-line) message into one short line."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


# held while file descriptor 2 points into a capture: a line for the user waits for it (say_on_stderr)
_FD2 = threading.RLock()


@contextmanager
def captured_stderr() -> Iterator[list[str]]:
    """Capture what C libraries print on file descriptor 2 (libpng, libjpeg) while the block runs.

    Yields a list that holds the captured text once the block ends. Output of other threads during
    the block lands there too: a front end that draws progress meanwhile writes to its own dup of fd 2,
    and a line meant for the user goes through say_on_stderr.
    """
    captured: list[str] = []
    with _FD2:
        try:
            sys.stderr.flush()
        except (AttributeError, OSError, ValueError):
            pass
        saved = os.dup(2)
        with tempfile.TemporaryFile() as tmp:
            os.dup2(tmp.fileno(), 2)
            try:
                yield captured
            finally:
                os.dup2(saved, 2)
                os.close(saved)
                tmp.seek(0)
                captured.append(tmp.read(4096).decode("utf-8", "replace"))


def say_on_stderr(text: str) -> None:
    """Print a line on stderr, never into another thread's capture: a stage still running on a worker thread
    when a run fails may be reading an image, and the one-line error went into its capture (lost)."""
    with _FD2:
        print(text, file=sys.stderr, flush=True)


def _open(path: str | Path, field: str, config: oiio.ImageSpec | None = None):
    """(ImageInput, spec) with the header checked: readable, has pixels, at most MAX_CHANNELS channels."""
    with captured_stderr() as noise:
        inp = oiio.ImageInput.open(str(path), config) if config is not None else oiio.ImageInput.open(str(path))
        detail = oiio.geterror() if inp is None else ""
    if inp is None:
        raise ShotError(path, field, f"cannot read image ({_one_line(detail or ''.join(noise)) or 'unknown format'})",
                        READ_FIX)
    spec = inp.spec()
    if spec.width <= 0 or spec.height <= 0 or spec.nchannels <= 0:
        inp.close()
        raise ShotError(path, field, f"image has no pixels ({spec.width}x{spec.height}, {spec.nchannels} channels)",
                        "re-export the drawing")
    if spec.nchannels > MAX_CHANNELS:
        inp.close()
        raise ShotError(path, field, f"image has {spec.nchannels} channels, at most {MAX_CHANNELS} are read",
                        "export it as RGB or RGBA")
    return inp, spec


def image_size(path: str | Path, field: str = "image") -> tuple[int, int]:
    """(height, width) read from the header only; raises ShotError if unreadable or without pixels."""
    inp, spec = _open(path, field)
    inp.close()
    return spec.height, spec.width


def read_image(path: str | Path, field: str = "image", max_side: int = MAX_SIDE) -> np.ndarray:
    """Read an image as float32 (H, W, C) in [0, 1], straight alpha; checks the size first."""
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp, spec = _open(path, field, config)
    if spec.width > max_side or spec.height > max_side:
        inp.close()
        raise ShotError(path, field, f"image is {spec.width}x{spec.height}, larger than {max_side}x{max_side}",
                        f"downscale the drawing to at most {max_side} px per side")
    with captured_stderr() as noise:
        pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
        damaged = inp.has_error
        detail = inp.geterror() if damaged else ""
        inp.close()
    if pixels is None or damaged:  # a truncated file: the decoder stops early, or fills the rest and says so
        why = _one_line(detail or "".join(noise))
        raise ShotError(path, field, f"cannot decode pixels ({why or 'the file is damaged'})",
                        "re-export the image (the file is truncated or damaged)")
    return np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)


@functools.lru_cache(maxsize=256)
def _pixel_problem(path: str, version: tuple[int, int], kind: str) -> tuple[str, str] | None:
    """(problem, fix) of one file version's pixels, or None; `version` = (size, mtime_ns) keys the cache."""
    try:
        img = read_image(path, "image")
    except ShotError as e:
        return e.problem, e.fix
    if not np.isfinite(img).all():
        return "contains NaN or infinite pixel values", "re-export it as an 8- or 16-bit PNG"
    if kind == "drawing":
        page = composite_over_white(to_rgba(img))
        if float(np.ptp(page.reshape(-1, 3), axis=0).max()) < BLANK_RANGE:
            return "the image is blank (one colour everywhere): there is no drawing", "give the keyframe's drawing"
    return None


def pixel_problem(path: str | Path, kind: str = "drawing") -> tuple[str, str] | None:
    """Decode an image once per file version and check its content: (problem, fix) or None when usable.

    kind 'drawing': finite values and not a blank page; 'mask': finite values.
    """
    st = os.stat(path)
    return _pixel_problem(str(Path(path).resolve()), (st.st_size, st.st_mtime_ns), kind)


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


def paper_under_clear(rgba: np.ndarray, clear_below: float = 0.5 / 255) -> np.ndarray:
    """(H, W, 4) straight alpha -> a copy whose colour is white (the paper) wherever alpha < clear_below.

    Invisible when composited, but a viewer or tool that drops alpha then shows one steady page: the blends
    leave black under full transparency, RIFE's frames white, and the keys whatever the scan held. The 8-bit
    default clears what rounds to alpha 0 in a PNG."""
    out = np.array(rgba, dtype=np.float32, copy=True)
    out[out[..., 3] < clear_below, :3] = 1.0
    return out


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
        replace_into(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
