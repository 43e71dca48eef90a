"""What the results view shows, read from the stage store: output frames, the image matrix and its paths (§5.2).

Frames and matrix are served from the store, not from an output folder, so a shot run by the CLI before
the editor opened shows its results too. Encoded PNGs are cached by the stage output's content hash.
"""
from __future__ import annotations

import threading
from collections import OrderedDict

import cv2
import numpy as np

from ops.preview import to_png_bytes
from ops.shotio.image_io import composite_over_white, to_rgba
from ops.types import BlendPaths, ImageMatrix, OutputFrames
from resources.store import Store

MATRIX_PAD = 2  # display pixels between the matrix's thumbnails


class Results:
    """Frames, matrix and paths of one shot partition, cached per content hash."""

    def __init__(self, store: Store, partition: str):
        self.store, self.partition = store, partition
        self._lock = threading.Lock()
        self._frames: tuple[str, OutputFrames] | None = None
        self._png: OrderedDict[tuple, bytes] = OrderedDict()

    def _read_frames(self) -> tuple[str, OutputFrames] | None:
        version = self.store.hash("inbetween_frames", self.partition)
        if version is None:
            return None
        with self._lock:
            if self._frames is None or self._frames[0] != version:
                self._frames = (version, self.store.read("inbetween_frames", self.partition))
            return self._frames

    def _remember(self, key: tuple, data: bytes) -> bytes:
        with self._lock:
            self._png[key] = data
            while len(self._png) > 256:
                self._png.popitem(last=False)
        return data

    def frames_info(self) -> dict | None:
        """{"version", "count", "times", "alphas", "size", "blend"} of the stored output frames, or None."""
        got = self._read_frames()
        if got is None:
            return None
        version, out = got
        return {"version": version, "count": int(len(out.times)), "times": out.times.tolist(),
                "alphas": out.alphas.tolist(), "size": list(out.frames.shape[1:3]), "blend": out.blend}

    def frame_png(self, i: int) -> bytes | None:
        """Output frame i as an 8-bit straight-alpha RGBA PNG, or None when there is no such frame."""
        got = self._read_frames()
        if got is None or not 0 <= i < len(got[1].times):
            return None
        key = ("frame", got[0], i)
        with self._lock:
            if key in self._png:
                return self._png[key]
        return self._remember(key, to_png_bytes(got[1].frames[i]))

    def paths_info(self, seg: int = 0) -> dict | None:
        """Segment seg's optimal and diagonal paths through I(alpha, t): alpha index per time (the segment's
        local time, 0 at its first key), costs, abrupt transitions."""
        version = self.store.hash(f"seg{seg}/optimal_path", self.partition)
        if version is None:
            return None
        paths: BlendPaths = self.store.read(f"seg{seg}/optimal_path", self.partition)

        def path(p):
            return {"alpha_index": p.alpha_index.tolist(), "cost": float(p.cost),
                    "step_costs": p.step_costs.tolist(), "abrupt": p.abrupt.astype(bool).tolist()}

        return {"version": version, "segment": seg, "matrix_version": self.store.hash(f"seg{seg}/rife_matrix", self.partition),
                "times": paths.times.tolist(), "alphas": paths.alphas.tolist(),
                "optimal": path(paths.optimal), "diagonal": path(paths.diagonal)}

    def matrix_png(self, thumb: int, seg: int = 0) -> bytes | None:
        """Segment seg's I(alpha, t) as a grid of thumb-px cells over white (columns = t, rows = alpha from 0 at
        the top)."""
        version = self.store.hash(f"seg{seg}/rife_matrix", self.partition)
        if version is None:
            return None
        key = ("matrix", version, thumb)
        with self._lock:
            if key in self._png:
                return self._png[key]
        matrix: ImageMatrix = self.store.read(f"seg{seg}/rife_matrix", self.partition)
        return self._remember(key, to_png_bytes(matrix_grid(matrix.frames, thumb)))


def matrix_grid(frames: np.ndarray, thumb: int, pad: int = MATRIX_PAD) -> np.ndarray:
    """(T, A, H, W, 4) -> (A (thumb + pad) + pad, T (thumb + pad) + pad, 3) float32 grid of thumbnails over white.

    Cell (t, a) has its top-left corner at (pad + t (thumb + pad), pad + a (thumb + pad)); each frame is
    scaled to fit thumb x thumb and centred.
    """
    n_t, n_a, h, w = frames.shape[:4]
    grid = np.full((n_a * (thumb + pad) + pad, n_t * (thumb + pad) + pad, 3), 0.85, np.float32)
    s = thumb / max(h, w)
    nh, nw = max(1, round(h * s)), max(1, round(w * s))
    for t in range(n_t):
        for a in range(n_a):
            small = cv2.resize(composite_over_white(to_rgba(np.asarray(frames[t, a]))), (nw, nh),
                               interpolation=cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR)
            x, y = pad + t * (thumb + pad), pad + a * (thumb + pad)
            cell = np.ones((thumb, thumb, 3), np.float32)
            cell[(thumb - nh) // 2:(thumb - nh) // 2 + nh, (thumb - nw) // 2:(thumb - nw) // 2 + nw] = small.reshape(nh, nw, 3)
            grid[y:y + thumb, x:x + thumb] = cell
    return grid
