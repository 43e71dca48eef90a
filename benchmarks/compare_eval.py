"""Two `inbetween eval` outputs of the same shots, side by side: what a change did to every shot and to issue 27's bars.

A change to the method is judged on whole sets (docs/benchmarks.md): the mean of the interior frames, but also
which shots move and how far, whether every shot stays ahead of RIFE-direct, and how many shots' lower lane
reaches the lane-agreement goal. This reads each folder's results.csv (per frame, as `inbetween eval` writes
it), so two runs of any code compare, and prints per shot ours before and after, RIFE-direct, the lead after and
the lower lane before and after (only the shots that moved, unless --all), then one line of totals. Shots
evaluated in one folder only are named and left out of the means.

    python benchmarks/compare_eval.py BEFORE_DIR AFTER_DIR [--all] [--moved DB] [--lane-goal DB]
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ops.evaluation.baselines import summarize  # noqa: E402

LANE_GOAL_DB = 25.0  # issue 27: each shot's lower lane at least this far (PSNR) from the other key's drawing


@dataclass
class ShotScores:
    """One evaluation's per-shot numbers, dB (NaN where the evaluation has none)."""

    ours: pd.Series  # shot -> mean PSNR of our interior frames
    rife: pd.Series  # shot -> RIFE-direct's
    lane_min: pd.Series  # shot -> the lower lane's agreement with the other key


def read_scores(folder: Path) -> ShotScores:
    """Per-shot scores from an `inbetween eval` folder's results.csv."""
    path = Path(folder) / "results.csv"
    if not path.is_file():
        raise SystemExit(f"error: {path}: no results.csv; give the --out folder of an `inbetween eval` run")
    table = pd.read_csv(path)
    per_shot = summarize(table[table["method"] != "lane_agreement"])
    by_method = per_shot.pivot(index="shot", columns="method", values="psnr")
    lanes = table[table["method"] == "lane_agreement"].groupby("shot")["psnr"].min()
    return ShotScores(_method(by_method, "ours"), _method(by_method, "rife_direct"), lanes)


def _method(by_method: pd.DataFrame, name: str) -> pd.Series:
    """shot -> PSNR of one method (empty where the evaluation has none: a run without RIFE-direct)."""
    return by_method[name] if name in by_method else pd.Series(dtype=float)


def compare(before: ShotScores, after: ShotScores, lane_goal: float = LANE_GOAL_DB) -> tuple[pd.DataFrame, dict]:
    """(per shot in both evaluations: ours before / after / change, rife, lead after, lower lane before / after;
    totals: shots, means, shots ahead of RIFE-direct and lanes at the goal before and after, shots in one only)."""
    shots = sorted(set(before.ours.index) & set(after.ours.index))
    only = sorted(set(before.ours.index) ^ set(after.ours.index))
    rife = after.rife.reindex(shots).fillna(before.rife.reindex(shots))
    table = pd.DataFrame({
        "ours_before": before.ours.reindex(shots), "ours_after": after.ours.reindex(shots), "rife": rife,
        "lane_before": before.lane_min.reindex(shots), "lane_after": after.lane_min.reindex(shots)}, index=shots)
    table["change"] = table["ours_after"] - table["ours_before"]
    table["lead"] = table["ours_after"] - table["rife"]
    with_rife = table["rife"].notna()
    with_lanes = table["lane_before"].notna() | table["lane_after"].notna()
    totals = {
        "shots": len(shots), "only_in_one": only,
        "mean_before": float(table["ours_before"].mean()), "mean_after": float(table["ours_after"].mean()),
        "with_rife": int(with_rife.sum()),
        "ahead_before": int((table["ours_before"] > table["rife"])[with_rife].sum()),
        "ahead_after": int((table["ours_after"] > table["rife"])[with_rife].sum()),
        "with_lanes": int(with_lanes.sum()), "lane_goal": lane_goal,
        "lanes_before": int((table["lane_before"] >= lane_goal).sum()),
        "lanes_after": int((table["lane_after"] >= lane_goal).sum()),
    }
    return table, totals


def _db(v: float, sign: bool = False) -> str:
    """A dB value to 3 decimals (signed with `sign`), blank where there is none."""
    return "" if not np.isfinite(v) else (f"{v:+.3f}" if sign else f"{v:.3f}")


def report(table: pd.DataFrame, totals: dict, moved: float = 0.005, everything: bool = False) -> str:
    """The comparison as text: a row per shot that moved by `moved` dB or more (every shot with `everything`),
    then the totals."""
    rows = table if everything else table[table["change"].abs() >= moved]
    lines = [f"{'shot':44s} {'ours before':>11s} {'after':>8s} {'change':>7s} {'RIFE':>7s} {'lead':>7s} "
             f"{'lane before':>11s} {'after':>7s}"]
    for shot, r in rows.iterrows():
        lines.append(f"{shot[:44]:44s} {_db(r.ours_before):>11s} {_db(r.ours_after):>8s} {_db(r.change, True):>7s} "
                     f"{_db(r.rife):>7s} {_db(r.lead, True):>7s} {_db(r.lane_before):>11s} {_db(r.lane_after):>7s}")
    if not len(rows):
        lines.append(f"(no shot moved by {moved:g} dB or more)")
    t = totals
    lines.append(f"{t['shots']} shots: ours {t['mean_before']:.3f} -> {t['mean_after']:.3f} dB "
                 f"({t['mean_after'] - t['mean_before']:+.3f}); ahead of RIFE-direct {t['ahead_before']} -> "
                 f"{t['ahead_after']} of {t['with_rife']}; lower lane >= {t['lane_goal']:g} dB {t['lanes_before']} -> "
                 f"{t['lanes_after']} of {t['with_lanes']}")
    if t["only_in_one"]:
        lines.append(f"evaluated in one folder only (left out): {', '.join(t['only_in_one'])}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path, help="an `inbetween eval --out` folder")
    ap.add_argument("after", type=Path, help="another, of the same shots")
    ap.add_argument("--all", action="store_true", help="every shot, not only those that moved")
    ap.add_argument("--moved", type=float, default=0.005, help="dB: a shot moved by this much or more is listed")
    ap.add_argument("--lane-goal", type=float, default=LANE_GOAL_DB, help="dB: the lane agreement counted")
    args = ap.parse_args(argv)
    table, totals = compare(read_scores(args.before), read_scores(args.after), args.lane_goal)
    print(report(table, totals, args.moved, args.all))


if __name__ == "__main__":
    main()
