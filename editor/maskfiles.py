"""Manual mask files as the shot format wants them: 8-bit grey PNG, 255 = inside, 0 = outside, keyframe size.

Uploads from the page (or a script) may be any PNG: inside is where the pixel is light (mean colour >= 128)
and, when it has alpha, opaque (alpha >= 128), the same rule the masks stage applies when it reads a mask.
Uploads are staged in memory until a saved shot.json names them (editor/shotfile.py).
"""
from __future__ import annotations

import re
import threading
from pathlib import PurePosixPath

import cv2
import numpy as np

from ops.errors import ShotError

NAME = re.compile(r"^[A-Za-z0-9_\-][A-Za-z0-9_.\-/]*\.png$")


def check_name(name: str, protected: set[str]) -> str:
    """A mask file name relative to the shot directory: a .png path that stays inside it and is no drawing."""
    parts = PurePosixPath(name).parts
    if not NAME.match(name) or ".." in parts or name.startswith("/"):
        raise ShotError(name, "mask name", "must be a .png path inside the shot directory (letters, digits, _ - . /)",
                        "name it like key1_occ0.png")
    if name in protected:
        raise ShotError(name, "mask name", "is a keyframe of the shot", "give the mask a name of its own")
    return name


def decode_mask(data: bytes, size: tuple[int, int], name: str) -> np.ndarray:
    """(H, W) bool inside-mask of an uploaded image; ShotError if undecodable or not the keyframe size (H, W)."""
    arr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED) if data else None
    if arr is None:
        raise ShotError(name, "mask", "is not a readable image", "upload a PNG, white = inside")
    if arr.dtype == np.uint16:
        arr = (arr >> 8).astype(np.uint8)
    if arr.shape[:2] != tuple(size):
        raise ShotError(name, "mask", f"is {arr.shape[1]}x{arr.shape[0]}, keyframes are {size[1]}x{size[0]}",
                        "export the mask at the keyframe size")
    if arr.ndim == 2:
        return arr >= 128
    inside = arr[..., :3].mean(axis=2) >= 128 if arr.shape[2] >= 3 else arr[..., 0] >= 128
    if arr.shape[2] in (2, 4):
        inside &= arr[..., -1] >= 128
    return inside


def encode_mask(inside: np.ndarray) -> bytes:
    """(H, W) bool -> 8-bit grey PNG bytes, 255 = inside."""
    ok, buf = cv2.imencode(".png", np.where(inside, 255, 0).astype(np.uint8))
    if not ok:
        raise OSError("cannot encode mask as PNG")
    return buf.tobytes()


class Staging:
    """Mask uploads waiting for the shot.json that names them: {relative name: normalized PNG bytes}."""

    def __init__(self):
        self._files: dict[str, bytes] = {}
        self._lock = threading.Lock()

    def put(self, name: str, png: bytes) -> None:
        with self._lock:
            self._files[name] = png

    def get(self, name: str) -> bytes | None:
        with self._lock:
            return self._files.get(name)

    def snapshot(self) -> dict[str, bytes]:
        with self._lock:
            return dict(self._files)

    def discard(self, names, only_if: dict[str, bytes] | None = None) -> None:
        """Forget the named uploads (those replaced since `only_if` was taken stay staged)."""
        with self._lock:
            for n in names:
                if only_if is None or self._files.get(n) is only_if.get(n):
                    self._files.pop(n, None)
