"""Each lane's agreement with the other key, recomputed with the code checked out now, in about a second a lane.

A change to texturing, deformation or registration shows first in the lanes: each side stage
(`seg{s}/key{k}/deformed_frames`) renders its lane at the other key's pose and measures it against that key's
drawing (ops/evaluation/lane_checks.py). This recomputes only those stages, from the parents a finished run or
`inbetween eval` stored under INBETWEEN_HOME, and prints per lane the agreement that run recorded, the one now,
the registration's weight at the other key and the CPU seconds; then per shot the lower lane, and how many shots
reach 25 dB (issue 27's bar). The four evaluated sets' 92 lanes take about two minutes, against ten for an
evaluation; what the frames do still needs `inbetween eval` (docs/lanes.md: lanes that agree better do not always
make better frames). Nothing is written to the store.

    python benchmarks/bench_lanes.py INBETWEEN_HOME SHOTS_ROOT [--only SUBSTRING ...]
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from assets.graph import side  # noqa: E402
from assets.run.execute import _recorded_lane_agreement  # noqa: E402
from benchmarks.bench_pipeline import compute_alone  # noqa: E402
from ops.shotio.load import load_shot  # noqa: E402
from resources.store import Store  # noqa: E402

BAR_DB = 25.0  # issue 27's lane agreement


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("home", type=Path, help="INBETWEEN_HOME of a finished run or evaluation")
    ap.add_argument("shots", type=Path, help="the folder of the shots it ran")
    ap.add_argument("--only", nargs="*", default=None, help="shots whose name contains one of these")
    args = ap.parse_args()
    store = Store(args.home / "storage")
    print(f"{'shot':44s} {'lane':26s} {'stored':>7s} {'now':>7s} {'change':>7s} {'weight':>6s} {'cpu s':>6s}")
    stored: dict[str, list[float]] = {}  # per shot, its lanes' recorded agreement (nan: a run that kept none)
    now: dict[str, list[float]] = {}
    for folder in sorted(p for p in args.shots.iterdir() if (p / "shot.json").exists()):
        if args.only and not any(o in folder.name for o in args.only):
            continue
        shot = load_shot(folder)
        for s in range(shot.n_segments if shot.n_keys > 1 else 0):  # one drawing: no other key to agree with
            recorded = _recorded_lane_agreement(store, folder.name, shot, s)
            for k in shot.segment_keys(s):
                name = side(s, k, "deformed_frames")
                if store.hash(name, folder.name) is None:  # not run in this home
                    continue
                o = [j for j in shot.segment_keys(s) if j != k][0]
                before = recorded[f"key{k}->key{o}"]
                before = float("nan") if before is None else float(before)
                result, cpu = compute_alone(args.home, folder, name)
                after = result.metadata["agreement_db"]
                stored.setdefault(folder.name, []).append(before)
                now.setdefault(folder.name, []).append(after)
                weight = result.metadata.get("registration_weight_at_other_key", float("nan"))
                print(f"{folder.name[:44]:44s} {name:26s} {before:7.2f} {after:7.2f} {after - before:+7.2f} "
                      f"{weight:6.3f} {cpu:6.2f}", flush=True)
    if not now:
        sys.exit(f"{args.home / 'storage'}: no stored lane of a two-key shot in {args.shots}")
    changes = np.array([a - b for s in now for a, b in zip(now[s], stored[s])])
    lanes = sum(len(v) for v in now.values())
    if np.isfinite(changes).any():
        print(f"\n{lanes} lanes, mean change {np.nanmean(changes):+.3f} dB, least {np.nanmin(changes):+.2f} "
              f"({int(np.isfinite(changes).sum())} with a recorded agreement)")
    lower_now = {s: float(np.min(v)) for s, v in now.items()}
    lower_stored = {s: float(np.min(v)) for s, v in stored.items()}  # nan where a lane kept none
    print(f"shots whose lower lane reaches {BAR_DB:g} dB: {sum(v >= BAR_DB for v in lower_now.values())} now, "
          f"{sum(v >= BAR_DB for v in lower_stored.values())} recorded, of {len(now)}")
    for s in now:
        if not lower_now[s] >= BAR_DB or not lower_stored[s] >= BAR_DB:
            print(f"  {s}: {lower_stored[s]:.2f} -> {lower_now[s]:.2f}")


if __name__ == "__main__":
    main()
