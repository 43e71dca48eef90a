"""Per segment both sides meet: RIFE image matrix -> quality metrics -> optimal path -> frames (§5.2); the shot's
output joins the segments (a one-drawing shot's is its deformed drawing)."""
from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import numpy as np

from ops import preview
from ops.blending.contact_sheet import matrix_contact_sheet, output_row
from ops.blending.image_matrix import alpha_grid, network_calls_bound
from ops.blending.key_fallback import with_key_fallback
from ops.blending.local_alpha import local_frames
from ops.blending.path import diagonal_path, optimal_path
from ops.blending.path_cells import path_matrix
from ops.blending.quality import (
    interpolation_quality,
    quality_inputs,
    quality_table,
)
from ops.blending.select import select_frames
from ops.types import BlendPaths, DeformedSequence, ImageMatrix, OutputFrames

from . import progress
from .compute import StageDef, StageEnv, StageResult, stage
from .graph import side

if TYPE_CHECKING:  # pandas is imported by the stages that build tables, not with the Definitions
    import pandas as pd


def _sides(env: StageEnv, s: int) -> tuple[DeformedSequence, DeformedSequence]:
    """Segment s's two deformed sequences: its first key's side, then its last key's."""
    a, b = env.shot.segment_keys(s)
    return env.read(side(s, a, "deformed_frames")), env.read(side(s, b, "deformed_frames"))


class _CountedRife:
    """The RIFE network, reporting each batch of blends as a `progress` event of its stage: the longest stage
    tells a front end (the editor's rerun panel) how far it is. `bound` is the most blends it can take
    (ops.blending.image_matrix.network_calls_bound)."""

    def __init__(self, rife, partition: str, stage: str, bound: int):
        self._rife, self._partition, self._stage, self.bound, self.done = rife, partition, stage, bound, 0
        self._lock = threading.Lock()

    def midpoint_tensors(self, a0, a1, *args, **kwargs):
        return self._counted(len(a0), self._rife.midpoint_tensors(a0, a1, *args, **kwargs))

    def midpoint_flow_mask(self, a0, a1, *args, **kwargs):
        return self._counted(len(a0), self._rife.midpoint_flow_mask(a0, a1, *args, **kwargs))

    def _counted(self, pairs: int, out):
        with self._lock:  # the matrix may call from several threads (build_image_matrix): counts in order
            self.done += pairs
            progress.emit(self._partition, self._stage, "progress", done=self.done, bound=self.bound)
        return out

    def __getattr__(self, name):
        return getattr(self._rife, name)


def _rife_matrix(s: int):
    def compute(env: StageEnv) -> StageResult:
        """I(alpha, t): RIFE blends of the segment's two deformed sequences on a dyadic alpha grid."""
        return _matrix(env, s)

    return compute


def _matrix(env: StageEnv, s: int) -> StageResult:
    """I(alpha, t): RIFE blends of the two deformed sequences on a dyadic alpha grid, and the flow at alpha 1/2.

    Only the cells the output's path (Settings.blend) takes are blended, and the cells their bisection needs:
    the path is known from q and Q once the alpha-1/2 flows are (ops/blending/path_cells.py). The evaluation
    blends the other path's cells when it compares them.
    """
    seq0, seq1 = _sides(env, s)
    st = env.settings
    _, _, q, weight = quality_inputs(seq0, seq1, alpha_grid(st.alpha_depth))
    rife = _CountedRife(env.resource("rife").load(), env.partition, f"seg{s}/rife_matrix",
                        network_calls_bound(len(seq0.times), st.alpha_depth, st.matrix_cells))
    matrix = path_matrix(seq0, seq1, q, weight, rife, st.alpha_depth, st.epsilon, st.blend, env.resource("rife").batch,
                         st.matrix_cells)
    mid = matrix.frames[:, len(matrix.alphas) // 2]
    meta = {"T": len(matrix.times), "A": len(matrix.alphas), "inferences": rife.done,
            "cells_computed": int(matrix.computed.sum()), "cells": st.matrix_cells,
            "device": env.resource("rife").device}
    return StageResult(matrix, meta, preview.frame_strip(mid))


def _quality(s: int):
    def compute(env: StageEnv) -> StageResult:
        """Texture quality q(t, alpha) (visible unreliable share: inpainted or distorted) and interpolation quality
        Q(t) (flow divergence)."""
        return _quality_of(env, s)

    return compute


def _quality_of(env: StageEnv, s: int) -> StageResult:
    matrix: ImageMatrix = env.read(f"seg{s}/rife_matrix")
    seq0, seq1 = _sides(env, s)
    share0, share1, q, weight = quality_inputs(seq0, seq1, matrix.alphas)
    Q = interpolation_quality(matrix.flows, weight)
    table = quality_table(matrix.times, matrix.alphas, q, Q)
    meta = {"Q_max": float(Q.max()), "Q_mean": float(Q.mean()), "q_max": float(q.max()),
            "unreliable_share_key0": [round(float(s), 4) for s in share0],
            "unreliable_share_key1": [round(float(s), 4) for s in share1]}
    return StageResult(table, meta, None)


def _table_arrays(table: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(times (T,), alphas (A,), q (T, A), Q (T,)) from the long quality table."""
    times = np.sort(table["t"].unique())
    alphas = np.sort(table["alpha"].unique())
    wide = table.pivot(index="t", columns="alpha", values="q").loc[times, alphas]
    Q = table.groupby("t")["Q"].first().loc[times].to_numpy()
    return times, alphas, wide.to_numpy(), Q


def _paths(s: int):
    def compute(env: StageEnv) -> StageResult:
        """Shortest path through the matrix (Dijkstra) and the diagonal path alpha = t, with their costs."""
        return _paths_of(env, s)

    return compute


def _paths_of(env: StageEnv, s: int) -> StageResult:
    times, alphas, q, Q = _table_arrays(env.read(f"seg{s}/quality_metrics"))
    best = optimal_path(q, Q, alphas, epsilon=env.settings.epsilon)
    diag = diagonal_path(q, Q, alphas, times)
    paths = BlendPaths(times, alphas, best, diag)
    meta = {"cost_optimal": float(best.cost), "cost_diagonal": float(diag.cost),
            "alpha_optimal": [float(alphas[i]) for i in best.alpha_index],
            "abrupt_transitions": [int(i) for i in np.nonzero(best.abrupt)[0]]}
    return StageResult(paths, meta, None)


def _check_path(paths: BlendPaths, env: StageEnv) -> tuple[bool, str]:
    idx = paths.optimal.alpha_index
    ok = (len(idx) == len(paths.times) and paths.alphas[idx[0]] == 0.0 and paths.alphas[idx[-1]] == 1.0
          and bool(np.all(np.diff(paths.times) > 0)))
    return ok, f"alpha along the path: {[float(paths.alphas[i]) for i in idx]}"


def _frames(s: int):
    def compute(env: StageEnv) -> StageResult:
        """The segment's frames: at every time, the matrix cell the chosen path picks."""
        return _frames_of(env, s)

    return compute


def _frames_of(env: StageEnv, s: int) -> StageResult:
    matrix: ImageMatrix = env.read(f"seg{s}/rife_matrix")
    paths: BlendPaths = env.read(f"seg{s}/optimal_path")
    blend = env.settings.blend
    chosen = paths.optimal if blend == "optimal" else paths.diagonal
    T = len(matrix.times)
    frames = select_frames(matrix.frames, chosen.alpha_index, matrix.computed)
    meta = {"frames": T, "blend": blend, "cost": float(chosen.cost)}
    strength, sigma = env.settings.local_alpha, env.settings.key_fallback
    local = strength > 0 and matrix.masks is not None
    seq0, seq1 = _sides(env, s) if local or sigma > 0 else (None, None)
    if local:
        frames, moved = local_frames(frames, seq0, seq1, matrix, matrix.alphas[chosen.alpha_index], strength)
        meta["local_alpha_share"] = [round(float(m), 4) for m in moved]
    fallback = None
    if sigma > 0:  # where neither lane is reliable: the keys' own interpolation (one network call, or none)
        frames, fallback = with_key_fallback(frames, seq0, seq1, matrix.times,
                                          lambda: env.resource("rife").load(), sigma)
        meta["key_fallback_share"] = [round(float(x), 4) for x in (fallback >= 0.5).mean((1, 2))]
    out = OutputFrames(matrix.times.copy(), matrix.alphas[chosen.alpha_index].copy(), frames, blend)
    sheet = matrix_contact_sheet(matrix.frames, matrix.alphas, matrix.times, paths.optimal.alpha_index,
                                 paths.diagonal.alpha_index, thumb=72,
                                 computed=matrix.computed)
    # under the grid, the frames as output: per-pixel alpha included, tinted by the keys' interpolation's weight
    marks = [(fallback, preview.KEYS_TINT)] if fallback is not None and fallback.any() else []
    sheet = np.concatenate([sheet, output_row(frames, thumb=72, marks=marks)])
    return StageResult(out, meta, sheet)


def _shot_frames(env: StageEnv) -> StageResult:
    """The shot's animation, one frame per output frame: the segments' frames joined at their shared keys, or a
    one-drawing shot's deformed drawing (no blending)."""
    shot = env.shot
    if shot.n_keys == 1:
        seq: DeformedSequence = env.read(side(0, 0, "deformed_frames"))
        frames = seq.images
        alphas = np.zeros(len(frames))
        blend = "none"
    else:
        parts: list[OutputFrames] = [env.read(f"seg{s}/frames") for s in range(shot.n_segments)]
        frames = np.concatenate([p.frames[(1 if i else 0):] for i, p in enumerate(parts)])
        alphas = np.concatenate([p.alphas[(1 if i else 0):] for i, p in enumerate(parts)])
        blend = parts[0].blend
    out = OutputFrames(shot.times.copy(), alphas, frames.astype(np.float32, copy=False), blend)
    meta = {"frames": len(frames), "keys": shot.n_keys, "key_frames": list(shot.key_frames)}
    return StageResult(out, meta, preview.frame_strip(frames))


def segment_stages(s: int) -> list[StageDef]:
    """Segment s's blending of its two sides."""
    return [
        stage(f"seg{s}/rife_matrix", _rife_matrix(s), resources=("rife",)),
        stage(f"seg{s}/quality_metrics", _quality(s)),
        stage(f"seg{s}/optimal_path", _paths(s), checks={"path_endpoints_and_monotone_t": _check_path}),
        stage(f"seg{s}/frames", _frames(s), resources=("rife",)),
    ]


def shot_stages() -> list[StageDef]:
    return [stage("inbetween_frames", _shot_frames, group="shot")]
