"""Live re-pose: deform a keyframe's cached textured template into a pose the user drags (§4.3, §5.1).

The interactive, user-constrained puppet of Neural Puppet, on our template: each update solves the same
injective deformation as the pipeline (ops.geometry.deform), warm-started from the previous update's
vertices, and renders at display size with one sample per pixel (benchmarks/bench_editor.py measures an
update). The first update at a new time starts from the pipeline's own deformed vertices at the nearest
output time. While the pointer moves, a solve stops after LIVE_ITERATIONS quasi-Newton steps: every
iterate is fold-free (the line search never crosses the injectivity bound), so the view is a valid
deformation on its way to the minimum, and the next update goes on from it; when the drag ends, a
settling update solves to the pipeline's tolerance.

The live view is drawn by the pipeline's renderer (ops.appearance.render.Renderer), which keeps the
premultiplied textures from one update to the next and composites over white, the page's background,
instead of converting back to straight alpha: those two conversions were half of a render.
tests/editor/test_repose.py holds it equal to render() over white.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import cv2
import numpy as np

from ops.appearance.render import Renderer, to_supersampled
from ops.geometry.deform import Deformer
from ops.types import DeformedSequence, TexturedTemplate
from resources.store import Store

LIVE_ITERATIONS = 20  # per update while dragging: 20-40 ms of solve for a 384 px template on this machine


class OverWhite:
    """render() of one textured template, composited over white, as the page's opaque 8-bit RGBA."""

    def __init__(self, textured: TexturedTemplate):
        self.renderer = Renderer(textured)  # keeps the premultiplied textures from one update to the next

    def __call__(self, X: np.ndarray, pose: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """X (n, 2) vertices in output pixels, pose (J, 3) -> (h, w, 4) uint8 RGBA, opaque, over white."""
        rgb = self.renderer.over_white(X, pose, shape)
        return cv2.cvtColor(np.clip(rgb * 255.0 + 0.5, 0, 255).astype(np.uint8), cv2.COLOR_RGB2RGBA)


@dataclass
class ReposeResult:
    """One live update: the rendered image at display size and what it cost."""

    image: np.ndarray  # (h, w, 4) uint8 RGBA over white (opaque), display pixels
    scale: float  # display pixels per keyframe pixel
    solve_ms: float
    render_ms: float
    iterations: int
    cpu_ms: float  # CPU time of the process over solve + render: the cost, whatever else loads the machine


class Reposer:
    """One keyframe's textured template with its factorized solver and the last solution (warm start)."""

    def __init__(self, textured: TexturedTemplate, seq: DeformedSequence | None, mu: float, grad_tol: float = 0.01):
        """seq: the pipeline's deformation of the same template (warm starts), or None; mu, grad_tol as the pipeline's."""
        tpl = textured.template
        self.textured, self.grad_tol = textured, grad_tol
        self.draw = OverWhite(textured)
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

    def update(self, pose: np.ndarray, t: float, scale: float = 1.0, settle: bool = True) -> ReposeResult:
        """pose (J, 3) pixels/depth at time t -> the template deformed into it, rendered at `scale` (<= 1).

        settle False (a drag in progress): at most LIVE_ITERATIONS solver steps from the previous update.
        """
        limit = {} if settle else {"max_iter": LIVE_ITERATIONS}
        with self.lock:
            targets = self.textured.template.handle_targets(pose)
            cpu0 = time.process_time()
            t0 = time.perf_counter()
            try:
                res = self.deformer.solve(targets, x0=self._start(t), grad_tol=self.grad_tol, **limit)
            except ValueError:  # a warm start that folds (never expected): start from rest
                res = self.deformer.solve(targets, grad_tol=self.grad_tol, **limit)
            t1 = time.perf_counter()
            self.last_t, self.last_x = t, res.x
            h, w = self.textured.texture.shape[:2]
            shape = (max(1, round(h * scale)), max(1, round(w * scale)))
            # display pixel centres sit where the renderer's supersampled grid puts them: same mapping, factor scale
            image = self.draw(to_supersampled(res.x, scale) if scale != 1 else res.x, pose, shape)
            t2 = time.perf_counter()
            cpu = time.process_time() - cpu0
        return ReposeResult(image, scale, (t1 - t0) * 1e3, (t2 - t1) * 1e3, res.iterations, cpu * 1e3)


def png_bytes(rgba: np.ndarray) -> bytes:
    """(H, W, 4) uint8 RGBA -> PNG bytes, fast compression (a live view, not an archive)."""
    ok, buf = cv2.imencode(".png", cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGRA), [cv2.IMWRITE_PNG_COMPRESSION, 1])
    if not ok:
        raise OSError("cannot encode the live view as PNG")
    return buf.tobytes()


class Reposers:
    """The reposer of each keyframe in each of its segments, rebuilt when the stored textured template changes."""

    def __init__(self, store: Store, partition: str, mu: float, grad_tol: float):
        self.store, self.partition, self.mu, self.grad_tol = store, partition, mu, grad_tol
        self._cache: dict[tuple[int, int], tuple[str, Reposer]] = {}
        self._lock = threading.Lock()

    def get(self, k: int, seg: int = 0) -> Reposer | None:
        """Reposer of keyframe k in segment seg, or None while its textured template has not been computed."""
        name = f"seg{seg}/key{k}/textured_template"
        version = self.store.hash(name, self.partition)
        if version is None:
            return None
        with self._lock:
            cached = self._cache.get((k, seg))
            if cached and cached[0] == version:
                return cached[1]
            textured = self.store.read(name, self.partition)
            seq_name = f"seg{seg}/key{k}/deformed_frames"
            seq = self.store.read(seq_name, self.partition) if self.store.hash(seq_name, self.partition) else None
            reposer = Reposer(textured, seq, self.mu, self.grad_tol)
            self._cache[(k, seg)] = (version, reposer)
            return reposer
