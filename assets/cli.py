"""The `inbetween` command line (SHOT_FORMAT.md): run, batch, status, eval, ui.

`run` validates the shot, registers it as a partition of the persistent
instance, observes its sources, and materializes only the stages that are
stale or missing (plus what lies downstream; those skip their work when their
inputs turn out unchanged). Bad input prints one line and exits 2.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from ops.errors import ShotError

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1


def _settings(blend: str = "optimal", template: str = "optimized"):
    from resources.settings import PipelineSettings

    return PipelineSettings(blend=blend, template_mode=template)


class Session:
    """One persistent Dagster instance plus the Definitions built for the chosen settings."""

    def __init__(self, blend: str = "optimal", template: str = "optimized"):
        from .definitions import ensure_home

        ensure_home()
        import dagster as dg

        from .definitions import build_definitions

        self.dg = dg
        self.settings = _settings(blend, template)
        self.defs = build_definitions(self.settings)
        self.instance = dg.DagsterInstance.get()
        self.resources = self.defs.resources
        self.store = self.resources["io_manager"]

    def register(self, shot_dir: Path) -> str:
        from resources.shots import register_shot

        key = register_shot(Path(self.resources["shots"].registry), shot_dir)
        if not self.instance.has_dynamic_partition("shots", key):
            self.instance.add_dynamic_partitions("shots", [key])
        return key

    def observe(self, partition: str) -> None:
        result = self.defs.resolve_job_def("observe_sources").execute_in_process(
            instance=self.instance, partition_key=partition, raise_on_error=False)
        if not result.success:
            raise RuntimeError(f"observing the sources of {partition!r} failed")

    def configs(self) -> dict[str, dict]:
        """The config every stage would record now (see assets.stage)."""
        from .stage import STAGE_SPECS, stage_config

        return {name: stage_config(self.settings, uses, modules) for name, (uses, modules) in STAGE_SPECS.items()}

    def statuses(self, partition: str, stages: tuple[str, ...] | None = None):
        from .graph import STAGES
        from .provenance import asset_key, resolve

        return resolve(self.instance, partition, self.configs(), lambda n: self.store.exists(asset_key(n), partition),
                       stages or STAGES)

    def materialize(self, partition: str, names: list[str]):
        from .definitions import ALL_ASSETS
        from .provenance import asset_key

        return self.dg.materialize(ALL_ASSETS, instance=self.instance, partition_key=partition,
                                   selection=[asset_key(n) for n in names], resources=self.resources,
                                   raise_on_error=False, tags={"inbetween/cli": "run"})


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=2))
    os.replace(tmp, path)


def run_shot(shot_dir: str | Path, out_dir: str | Path, blend: str = "optimal", template: str = "optimized") -> dict:
    """Run one shot end to end; returns the report (also written to OUT_DIR/report.json)."""
    from ops.output import write_frames, write_preview_video
    from ops.shot import load_shot

    from .graph import STAGES
    from .provenance import asset_key, to_run

    start = time.perf_counter()
    shot = load_shot(shot_dir)  # validate before touching anything
    session = Session(blend, template)
    partition = session.register(Path(shot_dir))
    session.observe(partition)
    statuses = session.statuses(partition)
    names = to_run(statuses)
    executed: dict[str, dict] = {}
    if names:
        result = session.materialize(partition, names)
        for ev in result.get_asset_materialization_events():
            mat = ev.event_specific_data.materialization
            meta = mat.metadata
            executed[mat.asset_key.to_user_string()] = {
                "seconds": float(meta["seconds"].value) if "seconds" in meta else 0.0,
                "cached": bool(meta["cached"].value) if "cached" in meta else False}
        if not result.success:
            failed = [e for e in result.all_events if e.event_type_value == "STEP_FAILURE"]
            msg = failed[0].event_specific_data.error.message.strip().splitlines()[-1] if failed else "run failed"
            raise RuntimeError(f"{shot.root}: stage failed: {msg}")
    stages = {n: executed.get(n, {"seconds": 0.0, "cached": True}) for n in STAGES}
    frames = session.store.read(asset_key("inbetween_frames"), partition)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_frames(out, frames.frames)
    write_preview_video(out / "preview.gif", frames.frames)
    report = {"shot": shot.root, "partition": partition, "frames": int(len(frames.times)),
              "times": [float(t) for t in frames.times], "alphas": [float(a) for a in frames.alphas],
              "blend": blend, "template": template, "stages": stages,
              "seconds_total": round(time.perf_counter() - start, 3)}
    paths = session.store.read(asset_key("optimal_path"), partition)
    chosen = paths.optimal if blend == "optimal" else paths.diagonal
    report["path"] = {"cost": float(chosen.cost), "cost_optimal": float(paths.optimal.cost),
                      "cost_diagonal": float(paths.diagonal.cost),
                      "abrupt_transitions": [[float(paths.times[i]), float(paths.times[i + 1])]
                                             for i in range(len(chosen.abrupt)) if chosen.abrupt[i]]}
    _write_json(out / "report.json", report)
    return report


def _batch_worker(shot_dir: str, out_dir: str, blend: str, template: str) -> tuple[str, dict | None, str | None]:
    import torch

    torch.set_num_threads(1)  # two shots share two cores
    try:
        return shot_dir, run_shot(shot_dir, out_dir, blend, template), None
    except ShotError as e:
        return shot_dir, None, str(e)
    except Exception as e:  # one line per failed shot; other shots go on
        return shot_dir, None, f"{shot_dir}: {type(e).__name__}: {e}".splitlines()[0]


def batch(root: str | Path, out_dir: str | Path, workers: int = 2, blend: str = "optimal",
          template: str = "optimized") -> tuple[dict, list[str]]:
    """Every shot directory under root, `workers` at a time; returns (reports by shot name, errors)."""
    from .definitions import ensure_home

    ensure_home()
    shots = sorted(d for d in Path(root).iterdir() if (d / "shot.json").is_file())
    session = Session(blend, template)  # register partitions up front, one writer at a time
    for d in shots:
        session.register(d)
    reports, errors = {}, []
    import multiprocessing as mp

    with ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn")) as pool:
        futures = [pool.submit(_batch_worker, str(d), str(Path(out_dir) / d.name), blend, template) for d in shots]
        for f in as_completed(futures):
            shot_dir, report, error = f.result()
            if error:
                errors.append(error)
            else:
                reports[Path(shot_dir).name] = report
    return reports, errors


def status(shot_dir: str | Path) -> dict:
    """Which stages are fresh, stale (and why) or missing, after observing the sources."""
    from ops.shot import load_shot

    load_shot(shot_dir)
    session = Session()
    partition = session.register(Path(shot_dir))
    session.observe(partition)
    return {n: {"state": s.state, "causes": s.causes} for n, s in session.statuses(partition).items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="inbetween", description="Skeleton-driven inbetweening of bitmap drawings.")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("run", help="in-between one shot")
    p.add_argument("shot_dir")
    p.add_argument("--out", required=True)
    p.add_argument("--blend", choices=["optimal", "diagonal"], default="optimal")
    p.add_argument("--template", choices=["optimized", "single-layer"], default="optimized")
    b = sub.add_parser("batch", help="every shot under a root, in parallel")
    b.add_argument("shots_root")
    b.add_argument("--out", required=True)
    b.add_argument("--workers", type=int, default=2)
    b.add_argument("--blend", choices=["optimal", "diagonal"], default="optimal")
    b.add_argument("--template", choices=["optimized", "single-layer"], default="optimized")
    s = sub.add_parser("status", help="which stages of a shot are stale and why")
    s.add_argument("shot_dir")
    e = sub.add_parser("eval", help="evaluate shots that carry ground truth")
    e.add_argument("shots_root")
    e.add_argument("--out", default=None)
    sub.add_parser("ui", help="open the Dagster UI on this project's instance")
    args = parser.parse_args(argv)
    try:
        if args.command == "run":
            report = run_shot(args.shot_dir, args.out, args.blend, args.template)
            ran = [n for n, s in report["stages"].items() if not s["cached"]]
            print(f"{report['frames']} frames -> {Path(args.out) / 'frames'}  "
                  f"({len(ran)} stages executed, {report['seconds_total']:.1f} s)")
            return 0
        if args.command == "batch":
            t0 = time.perf_counter()
            reports, errors = batch(args.shots_root, args.out, args.workers, args.blend, args.template)
            for name, r in sorted(reports.items()):
                print(f"{name}: {r['frames']} frames, {r['seconds_total']:.1f} s")
            for err in errors:
                print(err, file=sys.stderr)
            print(f"{len(reports)} shots done, {len(errors)} failed, {time.perf_counter() - t0:.1f} s")
            return EXIT_BAD_INPUT if errors else 0
        if args.command == "status":
            for name, st in status(args.shot_dir).items():
                print(f"{name:28s} {st['state']:8s} {'; '.join(st['causes'])}")
            return 0
        if args.command == "eval":
            from .evaluation_cli import evaluate_root

            return evaluate_root(args.shots_root, args.out)
        if args.command == "ui":
            from .definitions import ensure_home

            ensure_home()
            root = Path(__file__).resolve().parent.parent
            os.execvp("dagster", ["dagster", "dev", "-w", str(root / "workspace.yaml")])
    except ShotError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except RuntimeError as e:
        print(f"error: {str(e).splitlines()[0]}", file=sys.stderr)
        return EXIT_FAILED
    return 0


if __name__ == "__main__":
    sys.exit(main())
