"""Throughput of the six original samples: in-process runs one after another, against two local Celery workers.

    python benchmarks/bench_farm.py [--scale 1.0] [--repeat 1] [--modes sequential batch farm]

Needs the `.[farm]` extra, redis-server and PostgreSQL (tests/farm/servers.py
starts throwaway ones on 127.0.0.1). Every mode starts from a fresh
INBETWEEN_HOME, runs the CLI as a user would (new processes, Dagster start-up
included) and is timed from the first command to the last frame written:
  sequential   `inbetween run SHOT` for each shot in turn (in-process; torch uses every core)
  batch x2     `inbetween batch --workers 2` (in-process, two shots at a time, one torch thread each)
  farm x2      `inbetween batch --executor celery --workers 6` and two `inbetween worker --threads 1`
               processes, Postgres storage: each stage a Celery task
For the farm it also prints where the time went: the stages' own seconds
(report.json), the seconds the workers' tasks took (their logs), and so the
cost per step of the Celery round trip (plan rebuilt from the module,
instance reconnected, events written to Postgres).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.assets.conftest import SAMPLES, scaled_copy  # noqa: E402
from tests.farm.local import local_farm  # noqa: E402

ORIGINAL = ("arm_cross", "legs_cross", "manual_masks", "no_occlusion", "tail", "two_poses")


def cli(args: list[str], env: dict) -> None:
    subprocess.run([sys.executable, "-m", "assets.cli", *args], env=env, cwd=ROOT, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def local_env(home: Path) -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT), "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster")}


def stage_seconds(out: Path) -> float:
    return sum(s["seconds"] for d in out.iterdir() for s in json.loads((d / "report.json").read_text())["stages"].values())


def children_cpu() -> float:
    """CPU seconds of the finished child processes so far (the CLI runs and everything they waited for)."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def sequential(shots: Path, tmp: Path) -> dict:
    env, out = local_env(tmp / "home-seq"), tmp / "out-seq"
    for d in sorted(shots.iterdir()):
        cli(["run", str(d), "--out", str(out / d.name)], env)
    return {"out": out}


def batch_in_process(shots: Path, tmp: Path) -> dict:
    out = tmp / "out-batch"
    cli(["batch", str(shots), "--out", str(out), "--workers", "2"], local_env(tmp / "home-batch"))
    return {"out": out}


def farm(shots: Path, tmp: Path) -> dict:
    """One farm batch; also the seconds the workers' tasks took, from their logs."""
    root = tmp / "farm"
    root.mkdir()
    with local_farm(root, visibility_timeout=3600.0) as f:  # no kills here: never hand a step out twice
        workers = [f.start_worker("w1"), f.start_worker("w2")]
        f.wait_ready()
        start = time.perf_counter()
        cli(["batch", str(shots), "--out", str(root / "out"), "--executor", "celery", "--workers", "6"], f.env)
        wall = time.perf_counter() - start
    tasks = [float(s) for w in workers for s in re.findall(r"succeeded in ([\d.]+)s", w.log.read_text())]
    return {"out": root / "out", "wall": wall, "tasks": sum(tasks), "steps": len(tasks)}


def measure(fn, shots: Path, tmp: Path) -> dict:
    """wall s, CPU s (this process's children: for the farm, the workers and Redis, not PostgreSQL's
    daemon) and the stages' own seconds of one mode."""
    cpu, start = children_cpu(), time.perf_counter()
    r = fn(shots, tmp)
    return {"wall": time.perf_counter() - start, **r, "cpu": children_cpu() - cpu, "stages": stage_seconds(r["out"])}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scale", type=float, default=1.0, help="resize the samples (1.0: as they are)")
    ap.add_argument("--repeat", type=int, default=1, help="measure each mode this many times; medians are printed")
    ap.add_argument("--modes", nargs="+", choices=["sequential", "batch", "farm"], default=["sequential", "batch", "farm"])
    args = ap.parse_args()
    modes = {"sequential": ("sequential", sequential), "batch": ("batch x2", batch_in_process), "farm": ("farm x2", farm)}
    results: dict[str, list[dict]] = {modes[m][0]: [] for m in args.modes}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        shots = tmp / "shots"
        for name in ORIGINAL:
            if args.scale == 1.0:
                shutil.copytree(SAMPLES / name, shots / name)
            else:
                scaled_copy(SAMPLES / name, shots / name, args.scale)
        for i in range(args.repeat):
            run = tmp / f"run{i}"
            run.mkdir()
            for m in args.modes:
                label, fn = modes[m]
                results[label].append(measure(fn, shots, run))
    n = len(ORIGINAL)
    med = lambda label, key: statistics.median(r[key] for r in results[label])
    print(f"{n} shots at scale {args.scale}, {args.repeat} repeat(s), medians; {os.cpu_count()} cores; "
          f"load average at the end {os.getloadavg()[0]:.1f}")
    print(f"{'mode':12s} {'wall s':>8s} {'shots/min':>10s} {'CPU s':>8s} {'stage s':>8s}")
    for label in results:
        wall = med(label, "wall")
        print(f"{label:12s} {wall:8.1f} {60 * n / wall:10.2f} {med(label, 'cpu'):8.1f} {med(label, 'stages'):8.1f}")
    if "farm x2" in results:
        wall, stages, tasks, steps = (med("farm x2", k) for k in ("wall", "stages", "tasks", "steps"))
        print(f"farm: the workers' tasks took {tasks:.1f} s for {steps:.0f} steps whose stages computed {stages:.1f} s: "
              f"{(tasks - stages) / max(steps, 1):.2f} s of Celery/Dagster round trip per step; "
              f"two workers busy {tasks / (2 * wall):.0%} of the batch's wall time")


if __name__ == "__main__":
    main()
