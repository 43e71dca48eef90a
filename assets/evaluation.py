"""Evaluation group: baselines, ground-truth metrics and lane agreement per shot, for any number of keys.

Methods: ours (the output), ours with the diagonal path, ours with the single-layer template, RIFE applied
to the keys alone, per segment, and a cross-dissolve; a one-drawing shot is compared with holding the
drawing still (and with its single-layer ablation). Only the output frames that have a reference frame are
scored. Lane agreement: each side of a segment deformed to the segment's other key, against that key's
drawing (PSNR, Chamfer): where the two lanes disagree, the blend between them ghosts.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ops import preview
from ops.appearance.lane import deform_lane, texture_lane
from ops.blending.image_matrix import complete_cells
from ops.blending.select import select_frames
from ops.errors import ShotError
from ops.evaluation.baselines import (
    blend_sequences,
    compare,
    cross_dissolve,
    held_drawing,
    lane_agreement,
    rife_direct,
    summarize,
)
from ops.evaluation.plate import over, paper_plate
from ops.geometry.topology import Solver, optimize_topology
from ops.shotio.image_io import read_image, to_rgba
from ops.shotio.load import ground_truth_files
from ops.types import BlendPaths, ImageMatrix, OutputFrames, Shot

from .compute import StageDef, StageEnv, StageResult, stage
from .graph import side


def _join(parts: list[np.ndarray]) -> np.ndarray:
    """Per-segment frame stacks (T_s, ...) joined into the shot's: each segment after the first starts at the
    key the previous one ended on."""
    return np.concatenate([p[(1 if i else 0):] for i, p in enumerate(parts)])


def _per_segment(shot: Shot, fn) -> np.ndarray:
    """The shot's frames from fn(s, keys (a, b), local times (T_s,)) -> (T_s, H, W, 4) per segment."""
    return _join([fn(s, shot.segment_keys(s), shot.segment_times(s)) for s in range(shot.n_segments)])


def _rife_direct(env: StageEnv) -> StageResult:
    """Frame interpolation alone: RIFE bisection between the keys of each segment to each of its frames (a
    one-drawing shot: the drawing held still)."""
    shot = env.shot
    if shot.n_keys == 1:
        frames = held_drawing(env.drawing(0), len(shot.times))
        method = "held_drawing"
    else:
        rife = env.resource("rife").load()
        frames = _per_segment(shot, lambda s, ab, t: rife_direct(env.drawing(ab[0]), env.drawing(ab[1]), t, rife))
        method = "rife_direct"
    return StageResult(OutputFrames(shot.times.copy(), shot.times.copy(), frames, method), {},
                       preview.frame_strip(frames))


def _single_layer(env: StageEnv) -> StageResult:
    """The ablation: the same pipeline with one flat layer per keyframe (no pockets, no cuts)."""
    shot, s = env.shot, env.settings
    refined = [env.read(f"key{k}/refined_masks") for k in range(shot.n_keys)]
    inpainter = env.resource("inpainter").get()
    solver = Solver(s.mu, s.grad_tol, s.max_iter)
    templates = [optimize_topology(refined[k], shot.key_pose(k), shot.key_pose(k), shot.skeleton,
                                   mode="single-layer", solver=solver) for k in range(shot.n_keys)]

    def lane(seg: int, k: int, other: int | None, backward: bool):
        textured, _ = texture_lane(templates[k], refined[k], None if other is None else refined[other],
                                   shot.key_pose(k), None if other is None else shot.key_pose(other), inpainter,
                                   s.mu, s.grad_tol, s.max_iter)
        return deform_lane(textured, shot.segment_times(seg), shot.segment_poses(seg), backward, shot.size, s.mu,
                           s.supersample)

    if shot.n_keys == 1:
        frames, alphas, cost = lane(0, 0, None, False).images, np.zeros(len(shot.times)), 0.0
    else:
        parts, alpha_parts, cost = [], [], 0.0
        rife = env.resource("rife").load()
        for seg in range(shot.n_segments):
            a, b = shot.segment_keys(seg)
            matrix, paths = blend_sequences(lane(seg, a, b, False), lane(seg, b, a, True), rife, s.alpha_depth,
                                            s.epsilon, s.matrix_cells)
            parts.append(select_frames(matrix.frames, paths.optimal.alpha_index))
            alpha_parts.append(matrix.alphas[paths.optimal.alpha_index])
            cost += float(paths.optimal.cost)
        frames, alphas = _join(parts), _join(alpha_parts)
    out = OutputFrames(shot.times.copy(), np.asarray(alphas, np.float64).copy(), frames, "single_layer")
    return StageResult(out, {"cost_optimal": cost}, preview.frame_strip(frames))


def ground_truth(shot: Shot) -> tuple[np.ndarray, np.ndarray] | None:
    """(output frame indices (G,), reference frames (G, H, W, 4)) of the shot's ground truth, or None.

    A v1 shot gives one reference per output time; a v2 shot any subset, named by output frame."""
    if shot.ground_truth is None:
        return None
    files = ground_truth_files(shot.ground_truth)
    if shot.version == 1 and len(files) != len(shot.times):
        raise ShotError(Path(shot.root) / "shot.json", "ground_truth",
                        f"folder has {len(files)} frames, the shot has {len(shot.times)} output times",
                        "give one reference frame 0000.png ... per output time")
    if not files:
        return None
    index = np.arange(len(files)) if shot.version == 1 else np.array([int(f.stem) for f in files])
    return index, np.stack([to_rgba(read_image(f, "ground_truth")) for f in files])


def _diagonal(env: StageEnv) -> np.ndarray:
    """The shot's frames along every segment's diagonal path (alpha = t): its cells are blended here, only to
    compare with them (the run blends only the output path's)."""
    shot, rife = env.shot, env.resource("rife")

    def segment(s: int, ab: tuple[int, ...], _t) -> np.ndarray:
        matrix: ImageMatrix = env.read(f"seg{s}/rife_matrix")
        paths: BlendPaths = env.read(f"seg{s}/optimal_path")
        seqs = [env.read(side(s, k, "deformed_frames")) for k in ab]
        matrix = complete_cells(matrix, seqs[0].images, seqs[1].images, rife.load(), paths.diagonal.alpha_index,
                                rife.batch)
        return select_frames(matrix.frames, paths.diagonal.alpha_index)

    return _per_segment(shot, segment)


def _lane_agreement(env: StageEnv, shot: Shot) -> list[dict]:
    """Per segment and side: the lane at the segment's other key (its last or first deformed frame) against that
    key's drawing over its paper; rows of the metrics table (method 'lane_agreement')."""
    rows = []
    for s in range(shot.n_keys - 1):
        for k in shot.segment_keys(s):
            other = [o for o in shot.segment_keys(s) if o != k][0]
            seq = env.read(side(s, k, "deformed_frames"))
            masks = env.read(f"key{other}/masks")
            at_other = seq.images[-1 if other > k else 0]
            psnr_db, chamfer_px = lane_agreement(at_other, env.drawing(other), masks.coverage, masks.paper)
            rows.append({"method": "lane_agreement", "lane": f"key{k}->key{other}", "frame": shot.key_frames[other],
                         "t": float(shot.times[shot.key_frames[other]]), "interior": False, "psnr": psnr_db,
                         "ssim": np.nan, "chamfer": chamfer_px})
    return rows


def _metrics(env: StageEnv) -> StageResult:
    """PSNR, SSIM and Chamfer of every method against the ground truth, per scored frame, all over the shot's
    paper; and the lanes' agreement at the keys."""
    import pandas as pd  # not with the Definitions (0.3 s): only where a table is built

    shot = env.shot
    agreement = _lane_agreement(env, shot)
    gt = ground_truth(shot)
    meta: dict = {"ground_truth": gt is not None}
    if agreement:
        meta["lane_agreement_psnr_min"] = float(min(r["psnr"] for r in agreement))
        meta["lane_agreement"] = {r["lane"]: round(float(r["psnr"]), 3) for r in agreement}
    if gt is None:
        cols = ["method", "frame", "t", "interior", "psnr", "ssim", "chamfer", "lane"]
        return StageResult(pd.DataFrame(agreement, columns=cols), meta)
    index, gt_frames = gt
    methods = {"ours": env.read("inbetween_frames").frames}
    if shot.n_keys > 1:
        methods["ours_diagonal"] = _diagonal(env)
    methods["single_layer"] = env.read("evaluation/single_layer").frames
    baseline = env.read("evaluation/rife_direct")
    methods[baseline.blend] = baseline.frames
    if shot.n_keys > 1:
        methods["cross_dissolve"] = _per_segment(
            shot, lambda s, ab, t: cross_dissolve(env.drawing(ab[0]), env.drawing(ab[1]), t))
    masks = [env.read(f"key{k}/masks") for k in range(shot.n_keys)]
    plate = paper_plate([env.drawing(k) for k in range(shot.n_keys)], [m.coverage for m in masks],
                        [m.paper for m in masks])
    scored = {name: over(frames[index], plate) for name, frames in methods.items()}
    interior = ~np.isin(index, shot.key_frames)
    table = compare(over(gt_frames, plate), scored, shot.times[index], frames=index, interior=interior)
    table = pd.concat([table.assign(lane=""), pd.DataFrame(agreement)], ignore_index=True) if agreement else \
        table.assign(lane="")
    means = summarize(table[table["method"] != "lane_agreement"]).set_index("method")
    mid = int(np.argmin(np.abs(index - (len(shot.times) - 1) / 2)))
    strip = preview.side_by_side([gt_frames[mid]] + [scored[m][mid] for m in scored], ["ground truth", *scored])
    meta.update({f"{m}_{c}": float(means.loc[m, c]) for m in means.index for c in ("psnr", "ssim", "chamfer")})
    return StageResult(table, meta, strip)


def evaluation_stages() -> list[StageDef]:
    return [
        stage("evaluation/rife_direct", _rife_direct, resources=("rife",), group="evaluation"),
        stage("evaluation/single_layer", _single_layer, resources=("rife", "inpainter"), group="evaluation"),
        stage("evaluation/metrics", _metrics, resources=("rife",), group="evaluation"),
    ]
