"""Live re-pose: deform a keyframe's cached textured template into a pose the user drags (§4.3, §5.1).

The interactive, user-constrained puppet of Neural Puppet, on our template: each update solves the same
injective deformation as the pipeline (ops.geometry.deform), warm-started from the previous update's
vertices, and renders at display size with one sample per pixel, so an update stays well under 100 ms
for a 384 px shot (benchmarks/bench_editor.py measures it). The first update at a new time starts from
the pipeline's own deformed vertices at the nearest output time.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from ops.appearance.render import render, to_supersampled
from ops.geometry.deform import Deformer
from ops.types import DeformedSequence, TexturedTemplate
from resources.store import Store


@dataclass
class ReposeResult:
    """One live update: the rendered RGBA at display size and what it cost."""

    image: np.ndarray  # (h, w, 4) float32 straight alpha, display pixels
    scale: float  # display pixels per keyframe pixel
    solve_ms: float
    render_ms: float
    iterations: int


class Reposer:
    """One keyframe's textured template with its factorized solver and the last solution (warm start)."""

    def __init__(self, textured: TexturedTemplate, seq: DeformedSequence | None, mu: float):
        """seq: the pipeline's deformation of the same template (warm starts), or None."""
        tpl = textured.template
        self.textured = textured
        self.deformer = Deformer(tpl.rest, tpl.faces, tpl.handles, mu=mu)
        ok = seq is not None and seq.vertices.shape[1:] == tpl.rest.shape
        self.frame_times = seq.times if ok else np.zeros(0)
        self.frame_vertices = seq.vertices if ok else np.zeros((0, *tpl.rest.shape))
        self.last_t: float | None = None
        self.last_x: np.ndarray | None = None
        self.lock = threading.Lock()

    def _start(self, t: float) -> np.ndarray | None:
        """Warm start (n, 2): the previous update at the same t, else the pipeline's vertices at the nearest t."""
        if self.last_x is not None and self.last_t == t:
            return self.last_x
        if len(self.frame_times):
            return self.frame_vertices[int(np.argmin(np.abs(self.frame_times - t)))]
        return None

    def update(self, pose: np.ndarray, t: float, scale: float = 1.0) -> ReposeResult:
        """pose (J, 3) pixels/depth at time t -> the template deformed into it, rendered at `scale` (<= 1)."""
        with self.lock:
            targets = self.textured.template.handle_targets(pose)
            t0 = time.perf_counter()
            try:
                res = self.deformer.solve(targets, x0=self._start(t))
            except ValueError:  # a warm start that folds (never expected): start from rest
                res = self.deformer.solve(targets)
            t1 = time.perf_counter()
            self.last_t, self.last_x = t, res.x
            h, w = self.textured.texture.shape[:2]
            shape = (max(1, round(h * scale)), max(1, round(w * scale)))
            # display pixel centres sit where the renderer's supersampled grid puts them: same mapping, factor scale
            image, _ = render(self.textured, to_supersampled(res.x, scale) if scale != 1 else res.x, pose, shape, 1)
            t2 = time.perf_counter()
        return ReposeResult(image, scale, (t1 - t0) * 1e3, (t2 - t1) * 1e3, res.iterations)


class Reposers:
    """The reposer of each keyframe, rebuilt when the stored textured template changes."""

    def __init__(self, store: Store, partition: str, mu: float):
        self.store, self.partition, self.mu = store, partition, mu
        self._cache: dict[int, tuple[str, Reposer]] = {}
        self._lock = threading.Lock()

    def get(self, k: int) -> Reposer | None:
        """Reposer of keyframe k, or None while its textured template has not been computed."""
        name = f"key{k}/textured_template"
        version = self.store.hash(name, self.partition)
        if version is None:
            return None
        with self._lock:
            cached = self._cache.get(k)
            if cached and cached[0] == version:
                return cached[1]
            textured = self.store.read(name, self.partition)
            seq_name = f"key{k}/deformed_frames"
            seq = self.store.read(seq_name, self.partition) if self.store.hash(seq_name, self.partition) else None
            reposer = Reposer(textured, seq, self.mu)
            self._cache[k] = (version, reposer)
            return reposer
