"""End-to-end numbers: cold and warm `inbetween run` per sample shot, and `batch` throughput.

    python benchmarks/bench_pipeline.py [--shots data_samples] [--only arm_cross ...]

Each measurement uses a fresh INBETWEEN_HOME in a temporary folder and runs the
CLI as a user would (a new process), so Dagster start-up is included.
Per-stage seconds come from the cold run's report.json.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def cli(args: list[str], home: Path) -> float:
    env = {**os.environ, "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster")}
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "assets.cli", *args], env=env, check=True, cwd=ROOT,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--shots", default=str(ROOT / "data_samples"))
    ap.add_argument("--only", nargs="*")
    args = ap.parse_args()
    shots = sorted(d for d in Path(args.shots).iterdir() if (d / "shot.json").is_file()
                   and (not args.only or d.name in args.only))
    sequential = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        print(f"{'shot':14s} {'size':>8s} {'cold s':>7s} {'warm s':>7s}   slowest stages (cold)")
        for d in shots:
            home, out = tmp / f"home-{d.name}", tmp / f"out-{d.name}"
            cold = cli(["run", str(d), "--out", str(out)], home)
            report = json.loads((out / "report.json").read_text())  # the cold run's stage timings
            warm = cli(["run", str(d), "--out", str(out)], home)
            sequential += cold
            stages = sorted(report["stages"].items(), key=lambda kv: -kv[1]["seconds"])[:3]
            from ops.shotio.image_io import image_size

            h, w = image_size(d / "key0.png")
            print(f"{d.name:14s} {w:>4d}x{h:<3d} {cold:7.1f} {warm:7.1f}   "
                  + ", ".join(f"{n} {s['seconds']:.2f}" for n, s in stages))
            print(f"{'':14s} all stages: " + ", ".join(f"{n}={s['seconds']:.2f}" for n, s in report["stages"].items()))
        home = tmp / "home-batch"
        batch = cli(["batch", args.shots, "--out", str(tmp / "out-batch")], home)
        print(f"\nsequential cold runs: {sequential:.1f} s for {len(shots)} shots")
        print(f"batch (2 workers):    {batch:.1f} s  -> throughput {sequential / batch:.2f}x")


if __name__ == "__main__":
    main()
