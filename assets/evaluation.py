"""Evaluation group: baselines and ground-truth metrics per shot (issue 5)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ops import preview
from ops.appearance.lane import deform_lane, texture_lane
from ops.blending.image_matrix import complete_cells
from ops.blending.select import select_frames
from ops.evaluation.baselines import blend_sequences, compare, cross_dissolve, rife_direct, summarize
from ops.evaluation.plate import over, paper_plate
from ops.geometry.topology import Solver, optimize_topology
from ops.shotio.image_io import read_image, to_rgba
from ops.shotio.load import ground_truth_files
from ops.types import BlendPaths, ImageMatrix, OutputFrames

from .stage import StageEnv, StageResult, stage_asset


def _rife_direct(env: StageEnv) -> StageResult:
    """Frame interpolation alone: RIFE bisection between the two keyframes to every output time."""
    shot = env.shot
    frames = rife_direct(env.drawing(0), env.drawing(1), shot.times, env.resource("rife").load())
    return StageResult(OutputFrames(shot.times.copy(), shot.times.copy(), frames, "rife_direct"), {},
                       preview.frame_strip(frames))


def _single_layer(env: StageEnv) -> StageResult:
    """The ablation: the same pipeline with one flat layer per keyframe (no pockets, no cuts)."""
    shot, s = env.shot, env.settings
    refined = [env.read(f"key{k}/refined_masks") for k in (0, 1)]
    inpainter = env.resource("inpainter").get()
    seqs = []
    for k in (0, 1):
        template = optimize_topology(refined[k], shot.key_pose(k), shot.key_pose(1 - k), shot.skeleton,
                                     mode="single-layer", solver=Solver(s.mu, s.grad_tol, s.max_iter))
        textured, _ = texture_lane(template, refined[k], refined[1 - k], shot.key_pose(k), shot.key_pose(1 - k),
                                   inpainter, s.mu, s.grad_tol, s.max_iter)
        seqs.append(deform_lane(textured, shot.times, shot.poses, k == 1, shot.size, s.mu, s.supersample))
    matrix, paths = blend_sequences(seqs[0], seqs[1], env.resource("rife").load(), s.alpha_depth, s.epsilon)
    frames = select_frames(matrix.frames, paths.optimal.alpha_index)
    out = OutputFrames(matrix.times.copy(), matrix.alphas[paths.optimal.alpha_index].copy(), frames, "single_layer")
    return StageResult(out, {"cost_optimal": float(paths.optimal.cost)}, preview.frame_strip(frames))


def _ground_truth(env: StageEnv) -> np.ndarray | None:
    """(T, H, W, 4) reference frames, or None when the shot has none."""
    shot = env.shot
    if shot.ground_truth is None:
        return None
    files = ground_truth_files(shot.ground_truth)
    if len(files) != len(shot.times):
        from ops.errors import ShotError

        raise ShotError(Path(shot.root) / "shot.json", "ground_truth",
                        f"folder has {len(files)} frames, the shot has {len(shot.times)} output times",
                        "give one reference frame 0000.png ... per output time")
    return np.stack([to_rgba(read_image(f, "ground_truth")) for f in files])


def _metrics(env: StageEnv) -> StageResult:
    """PSNR, SSIM and Chamfer of every method against the ground truth, per frame, all over the shot's paper."""
    gt = _ground_truth(env)
    if gt is None:
        import pandas as pd  # not with the Definitions (0.3 s): only where a table is built

        empty = pd.DataFrame(columns=["method", "frame", "t", "interior", "psnr", "ssim", "chamfer"])
        return StageResult(empty, {"ground_truth": False})
    shot = env.shot
    matrix: ImageMatrix = env.read("rife_matrix")
    paths: BlendPaths = env.read("optimal_path")
    # the matrix holds the output path's cells: the diagonal's are blended here, only to compare with it
    seqs = [env.read(f"key{k}/deformed_frames") for k in (0, 1)]
    for path in (paths.optimal, paths.diagonal):
        matrix = complete_cells(matrix, seqs[0].images, seqs[1].images, env.resource("rife").load(),
                                path.alpha_index, env.resource("rife").batch)
    methods = {
        "ours": select_frames(matrix.frames, paths.optimal.alpha_index),
        "ours_diagonal": select_frames(matrix.frames, paths.diagonal.alpha_index),
        "single_layer": env.read("evaluation/single_layer").frames,
        "rife_direct": env.read("evaluation/rife_direct").frames,
        "cross_dissolve": cross_dissolve(env.drawing(0), env.drawing(1), shot.times),
    }
    masks = [env.read(f"key{k}/masks") for k in (0, 1)]
    plate = paper_plate(env.drawing(0), env.drawing(1), masks[0].coverage, masks[1].coverage, masks[0].paper,
                        masks[1].paper)
    methods = {name: over(frames, plate) for name, frames in methods.items()}
    table = compare(over(gt, plate), methods, shot.times)
    means = summarize(table).set_index("method")
    mid = len(shot.times) // 2
    strip = preview.side_by_side([gt[mid]] + [methods[m][mid] for m in methods], ["ground truth", *methods])
    meta = {f"{m}_{c}": float(means.loc[m, c]) for m in means.index for c in ("psnr", "ssim", "chamfer")}
    return StageResult(table, meta, strip)


def evaluation_assets() -> list:
    return [
        stage_asset("evaluation/rife_direct", _rife_direct, resources=("rife",), group="evaluation"),
        stage_asset("evaluation/single_layer", _single_layer, resources=("rife", "inpainter"), group="evaluation"),
        stage_asset("evaluation/metrics", _metrics, resources=("rife",), group="evaluation"),
    ]
