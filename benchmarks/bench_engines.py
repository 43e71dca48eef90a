"""Which engine decides freshness and which schedules (docs/design.md, "Two engines"): ours against Dagster's.

1. Freshness of an unchanged shot, each in a new process as a user's command would be:
   - ours: `assets.run.plan` (shot files and the store; no Dagster, no torch);
   - Dagster's: load the Definitions and the instance, then ask Dagster's stale-status resolver (the one the
     UI uses) for every stage of the shot's partition.
2. A cold run of one shot:
   - ours: `inbetween run` (Dagster's in-process executor recording; the work-ahead computing on two threads);
   - Dagster's multiprocess executor (each step in its own process, two at a time), the work-ahead off.

    python benchmarks/bench_engines.py [--shot data_samples/arm_cross] [--repeats 3]

Prints wall and CPU seconds per measure and their ratio. The machine may be shared: run it alone.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

OURS = """
import sys
from assets.run import plan
p = plan(sys.argv[1])
print(sum(s.state != "fresh" for s in p.statuses.values()))
"""

DAGSTERS = """
import sys, warnings
warnings.filterwarnings("ignore")
import dagster as dg
from dagster._core.definitions.data_version import CachingStaleStatusResolver, StaleStatus
from dagster._core.loader import LoadingContextForTest
from assets.definitions import defs
from assets.graph import shot_graph
from assets.run import register
from assets.home import ensure_home
from assets.run.session import open_instance
from ops.shotio.load import load_shot
shot = load_shot(sys.argv[1])
partition = register(shot.root)
ensure_home()  # DAGSTER_HOME under INBETWEEN_HOME, as every command sets it
instance = open_instance()
resolver = CachingStaleStatusResolver(instance, defs.resolve_asset_graph(), LoadingContextForTest(instance))
stale = [n for n in shot_graph(shot.n_keys).stages
         if resolver.get_status(dg.AssetKey(n.split("/")), partition) != StaleStatus.FRESH]
print(len(stale))
"""

MULTIPROCESS = """
import sys, warnings
warnings.filterwarnings("ignore")
import dagster as dg
from assets.run import register
from assets.run.planning import plan
from assets.run.session import Session
from assets.home import ensure_home
from benchmarks.bench_engines import multiprocess_job
from ops.settings import Settings
ensure_home()  # DAGSTER_HOME under INBETWEEN_HOME, as every command sets it
p = plan(sys.argv[1])
session = Session.get(Settings())
session.ensure_partition(p.partition)
session.observe(p.partition, p.sources)
result = dg.execute_job(dg.reconstructable(multiprocess_job), session.instance,
                        tags={"dagster/partition": p.partition},
                        asset_selection=[dg.AssetKey(n.split("/")) for n in p.to_run])
print(result.success)
"""


def multiprocess_job():
    """The shot job on Dagster's multiprocess executor (two steps at a time), for `dg.reconstructable`."""
    import dagster as dg

    from assets.definitions import SHOT_SELECTION, defs

    job = dg.define_asset_job("multiprocess_shot", selection=SHOT_SELECTION,
                              executor_def=dg.multiprocess_executor.configured({"max_concurrent": 2}))
    return dg.Definitions(assets=defs.assets, jobs=[job], resources=defs.resources).resolve_job_def("multiprocess_shot")


def timed(argv: list[str], env: dict) -> tuple[float, float, str]:
    """(wall s, CPU s of the process and its children, stdout's last line) of one new process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{argv[:3]} failed: {done.stderr[-800:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    lines = done.stdout.strip().splitlines()
    return wall, cpu, lines[-1] if lines else ""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shot", type=Path, default=ROOT / "data_samples" / "arm_cross")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench_engines_"))
    try:
        shot = work / "shot"
        shutil.copytree(args.shot, shot)
        env = {**os.environ, "INBETWEEN_HOME": str(work / "home"), "PYTHONPATH": str(ROOT)}
        env.pop("DAGSTER_HOME", None)
        py = sys.executable
        rows = []
        wall, cpu, _ = timed([py, "-m", "assets.cli", "run", str(shot), "--out", str(work / "out")], env)
        rows.append(("cold run, ours (in-process + work-ahead)", wall, cpu))
        for name, code in (("freshness of the unchanged shot, ours", OURS),
                           ("freshness of the unchanged shot, Dagster's resolver", DAGSTERS)):
            runs = [timed([py, "-c", code, str(shot)], env) for _ in range(args.repeats)]
            best = min(runs)
            assert best[2] == "0", f"{name}: {best[2]} stages not fresh"
            rows.append((name, best[0], best[1]))
        env2 = {**env, "INBETWEEN_HOME": str(work / "home2")}
        wall, cpu, ok = timed([py, "-c", MULTIPROCESS, str(shot)], env2)
        rows.append((f"cold run, Dagster's multiprocess executor (success {ok})", wall, cpu))
        print(json.dumps({"shot": args.shot.name, "load": os.getloadavg()[0]}))
        print(f"{'measure':62s} {'wall s':>8s} {'CPU s':>8s}")
        for name, wall, cpu in rows:
            print(f"{name:62s} {wall:8.2f} {cpu:8.2f}")
        print(f"Dagster's freshness / ours: {rows[2][1] / rows[1][1]:.1f}x wall; "
              f"multiprocess cold / ours: {rows[3][1] / rows[0][1]:.2f}x wall")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
