"""`inbetween eval SHOTS_ROOT`: run every shot that has ground truth, then its evaluation group.

Prints the per-method means across shots and writes results.csv (per frame),
summary.csv, summary.md and figure.png (t = 0.5 comparison of the occlusion
shots) into --out (default: SHOTS_ROOT/../eval).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from ops import preview
from ops.errors import ShotError
from ops.evaluation.baselines import METHODS, summarize
from ops.shotio.image_io import read_image, to_rgba, write_image
from ops.shotio.load import ground_truth_files


def _markdown(df: pd.DataFrame) -> str:
    cols = list(df.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for _, row in df.iterrows():
        lines.append("| " + " | ".join(f"{v:.3f}" if isinstance(v, float) else str(v) for v in row) + " |")
    return "\n".join(lines) + "\n"


def evaluate_root(root: str | Path, out: str | Path | None = None, settings=None) -> int:
    from .run import RunInterrupted, StageFailed, evaluate_stages, run_shot, store

    root = Path(root)
    out = Path(out) if out else root.parent / "eval"
    out.mkdir(parents=True, exist_ok=True)
    shots = sorted(d for d in root.iterdir() if (d / "shot.json").is_file()
                   and json.loads((d / "shot.json").read_text()).get("ground_truth"))
    tables, figure_rows, failed = [], [], []
    st = store()
    for d in shots:
        try:  # one shot's failure is one line of the summary; the other shots are still scored (as batch does)
            run_shot(d, out / "runs" / d.name, settings)
            partition = evaluate_stages(d, settings)
        except (ShotError, StageFailed) as e:
            if isinstance(e, RunInterrupted):
                raise
            failed.append((d.name, " ".join(str(e).split()), isinstance(e, ShotError)))
            print(f"error: {failed[-1][1]}", file=sys.stderr)
            continue
        table = st.read("evaluation/metrics", partition)
        tables.append(table.assign(shot=d.name))
        if any(json.loads((d / "shot.json").read_text()).get("t_junctions") or []):
            figure_rows.append(_figure_row(st, partition, d))
    # the exit status batch gives: 1 when a stage failed, 2 when only inputs were bad (or there were none)
    failure_status = 2 if all(bad for *_, bad in failed) else 1
    if not tables:
        print(f"error: {root}: no shot with a ground_truth folder" if not failed else
              f"error: {root}: every shot failed", file=sys.stderr)
        return failure_status
    per_frame = pd.concat(tables, ignore_index=True)
    per_frame.to_csv(out / "results.csv", index=False)
    per_shot = summarize(per_frame)
    present = [m for m in METHODS if m in set(per_shot["method"])]
    overall = per_shot.groupby("method", sort=False)[["psnr", "ssim", "chamfer"]].mean().reindex(present).reset_index()
    per_shot.to_csv(out / "summary.csv", index=False)
    lanes = per_frame[per_frame["method"] == "lane_agreement"]
    md = "## Mean over interior frames, all shots\n\n" + _markdown(overall) + "\n## Per shot\n\n" + _markdown(per_shot)
    if len(lanes):
        agreement = lanes.groupby("shot", sort=False)[["psnr", "chamfer"]].agg(["min", "mean"])
        agreement.columns = [f"{a}_{b}" for a, b in agreement.columns]
        md += ("\n## Lane agreement: each lane at the other key's pose against that key's drawing\n\n"
               + _markdown(agreement.reset_index()))
    if failed:
        md += ("\n## Failed shots (not in the means above)\n\n| shot | error |\n|---|---|\n"
               + "".join(f"| {name} | {message.replace('|', '/')} |\n" for name, message, _ in failed))
    (out / "summary.md").write_text(md)
    if figure_rows:
        width = max(r.shape[1] for r in figure_rows)
        padded = [np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0)), constant_values=1.0) for r in figure_rows]
        write_image(out / "figure.png", np.concatenate(padded, axis=0))
    print(md)
    print(f"written: {out / 'summary.md'}, {out / 'results.csv'}" + (f", {out / 'figure.png'}" if figure_rows else ""))
    if failed:
        print(f"{len(failed)} of {len(shots)} shots failed: {', '.join(name for name, *_ in failed)}", file=sys.stderr)
        return failure_status
    return 0


def _figure_row(st, partition: str, shot_dir: Path) -> np.ndarray:
    """keys, ground truth, ours, RIFE-direct at the middle frame, one labelled row."""
    from ops.shotio.load import load_shot

    shot = load_shot(shot_dir)
    files = ground_truth_files(shot.ground_truth)
    frame_of = [int(f.stem) for f in files]
    pick = int(np.argmin(np.abs(np.array(frame_of) - (len(shot.times) - 1) / 2)))  # the reference nearest the middle
    mid = frame_of[pick]
    ours = st.read("inbetween_frames", partition).frames[mid]
    baseline = st.read("evaluation/rife_direct", partition)
    keys = [to_rgba(read_image(p)) for p in shot.keyframes]
    labels = [f"{shot_dir.name} key0", *(f"key{k}" for k in range(1, len(keys)))]
    row = preview.side_by_side([*keys, to_rgba(read_image(files[pick])), ours, baseline.frames[mid]],
                               [*labels, f"truth frame {mid}", "ours", baseline.blend.replace("_", " ")])
    return row
