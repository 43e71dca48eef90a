"""Running shots: validate, lock, plan, run the stages that are not fresh, settle a shot saved meanwhile, and
write the frames and the report; the same for the evaluation group and for exporting masks.

- `run_shot`: validate the shot, take its partition's lock (a second run of the same shot waits, and says
  so), plan, run the stages that are not fresh in one in-process Dagster execution, and write the frames
  and report. When every stage is fresh and the Dagster instance already records the current versions,
  Dagster is not started at all.
- A shot saved while it runs is run again on what was saved (`_settle`).
"""
from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ops import simd
from ops.errors import ShotError
from ops.settings import Settings
from ops.shotio.frames import DEFAULT_EXPORTS
from ops.shotio.load import load_shot
from ops.shotio.versions import source_versions
from ops.types import Shot

from .. import processes, progress
from ..graph import EVAL_STAGES, shot_graph, side
from .errors import StageFailed
from .locks import shot_lock
from .logs import log_path
from .planning import Plan, _remember_ui, code_records, plan, register, stage_warnings, store
from .session import Session, retry_database_locked
from .staging import StagedOutputs

EXECUTORS = ("in_process", "celery")  # celery: every step on a farm worker (assets/farm/, docs/production.md)


@retry_database_locked
def execute(p: Plan, settings: Settings, names: list[str], verbose: bool = False,
            executor: str = "in_process", outputs: dict[str, tuple[str, Any] | None] | None = None,
            on_computed: Callable[[str, str, Any], None] | None = None) -> dict[str, dict]:
    """Run `names` (plus everything needed to make the Dagster UI current); {stage: {seconds, cpu_seconds, cached}}.
    outputs: {stage: None} of the outputs the caller will read; those this process computes are filled in as
    (data version, value), so the caller need not read them back. on_computed(stage, data version, output): told
    of each new output as soon as it is computed, before Dagster records it (in process only)."""
    if executor == "celery":
        session = Session.get(settings)
        session.ensure_partition(p.partition)
        session.observe(p.partition, p.unobserved)  # what the instance observed before stays its latest
        result = session.materialize_farm(p.shot.root, p.partition, names, log_path(p.partition), verbose)
        return stage_timings(result.all_events)
    processes.pool()  # the workers' fork server imports the ops while this process imports the stages
    from ..ahead import Resources, working_ahead

    executed: dict[str, dict] = {}

    def on_event(ev: dict) -> None:
        if ev["event"] == "done" and ev["partition"] == p.partition:
            executed[ev["stage"]] = {"seconds": ev["seconds"], "cpu_seconds": ev["cpu_seconds"],
                                     "cached": ev["cached"]}

    # the stages compute as soon as their parents have, ahead of the steps that record them, from before
    # Dagster is imported: their outputs are stored and recorded by their steps alone, and a stage that needs a
    # resource waits for it (the network and the inpainter: until Dagster is imported). The sources' versions
    # are the ones the plan observed.
    resources = Resources()
    with progress.listen(on_event), working_ahead(p.partition, names, p.shot, p.sources, settings, store(),
                                                  resources, on_computed) as ahead:
        try:
            from ..resource_types import model_resources

            resources.provide_early(model_resources())  # as the Definitions will bind them: no stage waits
            session = Session.get(settings)  # for those while the Definitions and the instance are made
        except BaseException as e:
            resources.fail(e)
            raise
        resources.provide(session.resources)
        code_records()  # cached for the next plan, which needs them (this one may not have: a new home's first run)
        session.ensure_partition(p.partition)
        session.observe(p.partition, p.unobserved)  # what the instance observed before stays its latest
        session.materialize(p.shot.root, p.partition, p.graph, names, log_path(p.partition), verbose)
        if outputs is not None:
            for n in outputs.keys() & ahead.memory.keys():
                outputs[n] = (ahead.outcomes[n].version, ahead.memory[n])
    return executed


def read_output(name: str, partition: str, outputs: dict[str, tuple[str, Any] | None]) -> Any:
    """A stage's stored output: the value this process computed when it is the one stored (its data version
    is), else read from the store (a cached stage, or one another process wrote since)."""
    st = store()
    version, value = outputs.get(name) or (None, None)
    return value if version is not None and version == st.hash(name, partition) else st.read(name, partition)


def stage_timings(events) -> dict[str, dict]:
    """{stage: {seconds, cpu_seconds, cached}} from a run's materializations (steps that ran in other processes)."""
    out = {}
    for ev in events:
        if ev.event_type_value == "ASSET_MATERIALIZATION":
            mat = ev.event_specific_data.materialization
            meta = {k: getattr(v, "value", v) for k, v in mat.metadata.items()}
            out["/".join(mat.asset_key.path)] = {"seconds": meta.get("seconds", 0.0),
                                                 "cpu_seconds": meta.get("cpu_seconds", 0.0),
                                                 "cached": meta.get("cached", False)}
    return out


def run_shot(shot_dir: str | Path, out_dir: str | Path, settings: Settings | None = None, *,
             on_wait: Callable[[], None] | None = None, verbose: bool = False, executor: str = "in_process",
             exports: tuple[str, ...] = DEFAULT_EXPORTS, fps: float = 12.0, started: float | None = None) -> dict:
    """Run one shot end to end; returns the report (also written to OUT_DIR/report.json).

    executor: "in_process" (this process runs the stages) or "celery" (farm workers do; this process waits).
    exports: what OUT_DIR gets besides the PNG frames (ops.shotio.frames.EXPORTS), at `fps` frames per second.
    started: time.perf_counter() when the command began (the CLI's start, imports included): report.json's
    seconds_total counts from it, so the one time figure the front ends print is the wall clock's.
    """
    from ops.shotio.frames import write_outputs, write_report

    start = time.perf_counter() if started is None else started
    if (unheld := simd.unheld()) is not None:  # a script that imported numpy first: say so, once per process
        warnings.warn(unheld, RuntimeWarning, stacklevel=2)
    settings = settings or Settings()
    shot = load_shot(shot_dir)  # validate before touching anything
    partition = register(shot.root)
    out_dir = Path(out_dir)
    staged = StagedOutputs(out_dir, exports, fps)  # the frames' files written while Dagster records the last steps
    try:
        with shot_lock(partition, on_wait):
            # what the report reads: taken from the run where it computed them (a shot saved meanwhile with other
            # keys reads the rest from the store)
            outputs = dict.fromkeys(["inbetween_frames", *(f"seg{s}/optimal_path" for s in range(shot.n_keys - 1))])
            shot, executed = _settle(shot, settings, verbose, executor, outputs, staged.on_computed)
            st = store()
            frames = read_output("inbetween_frames", partition, outputs)
            names = plan_stages(shot)
            repairs = stage_warnings(partition, names)
            segments = [_segment_report(shot, s, read_output(f"seg{s}/optimal_path", partition, outputs), settings.blend,
                                        _recorded_lane_agreement(st, partition, shot, s))
                        for s in range(shot.n_keys - 1)]
        unrun = {"seconds": 0.0, "cpu_seconds": 0.0, "cached": True}
        stages = {n: {"executed": n in executed, **executed.get(n, unrun), "warnings": repairs.get(n, 0)} for n in names}
        report = {"shot": shot.root, "partition": partition, "frames": int(len(frames.times)),
                  "times": [float(t) for t in frames.times], "alphas": [float(a) for a in frames.alphas],
                  "keys": shot.n_keys, "key_frames": list(shot.key_frames),
                  "blend": settings.blend if segments else "none", "template": settings.template_mode, "stages": stages,
                  "frames_version": st.hash("inbetween_frames", partition), "segments": segments,
                  "simd": simd.state()}  # this process's; farm workers pin their own (ops/simd.py)
        if segments:  # the first segment's, where a two-key (v1) shot always had it
            report["path"] = {k: v for k, v in segments[0].items() if k not in ("keys", "frames", "lane_agreement_db")}
        report["seconds_total"] = round(time.perf_counter() - start, 3)  # so far: re-stamped once written
        write_outputs(out_dir, frames.frames, report, exports, fps, staged.folder(report["frames_version"]))
        report["seconds_total"] = round(time.perf_counter() - start, 3)
        write_report(out_dir, report)
        return report
    finally:
        staged.discard()


def plan_stages(shot: Shot) -> tuple[str, ...]:
    """The stages a run of this shot computes (its graph's, the evaluation group left out)."""
    return shot_graph(shot.n_keys).stages


def _recorded_lane_agreement(st, partition: str, shot: Shot, s: int) -> dict[str, float | None]:
    """{"key{k}->key{o}": dB} of segment s: each side's lane at the other key's pose against that key's drawing,
    as its deformed_frames stage recorded it (None where its record predates the measure)."""
    out = {}
    for k in shot.segment_keys(s):
        o = [j for j in shot.segment_keys(s) if j != k][0]
        _, recorded = st.provenance(side(s, k, "deformed_frames"), partition)
        out[f"key{k}->key{o}"] = ((recorded or {}).get("metrics") or {}).get("agreement_db")
    return out


def _segment_report(shot: Shot, s: int, paths, blend: str, agreement: dict[str, float | None]) -> dict:
    """Segment s in report.json: its keys and output frames, its path (alpha per frame), costs, abrupt steps, and
    its lanes' agreement with the other key (dB)."""
    chosen = paths.optimal if blend == "optimal" else paths.diagonal
    frames = shot.segment_frames(s)
    return {"keys": list(shot.segment_keys(s)), "frames": [int(frames[0]), int(frames[-1])],
            "lane_agreement_db": agreement,
            "alphas": [float(paths.alphas[i]) for i in chosen.alpha_index],
            "cost": float(chosen.cost), "cost_optimal": float(paths.optimal.cost),
            "cost_diagonal": float(paths.diagonal.cost),
            "abrupt_transitions": [[float(paths.times[i]), float(paths.times[i + 1])]
                                   for i in range(len(chosen.abrupt)) if chosen.abrupt[i]]}


SETTLE_ROUNDS = 3


def _settle(shot: Shot, settings: Settings, verbose: bool, executor: str = "in_process",
            outputs: dict[str, tuple[str, Any] | None] | None = None,
            on_computed: Callable[[str, str, Any], None] | None = None) -> tuple[Shot, dict[str, dict]]:
    """Run the stages that are not fresh until the shot on disk is the one they ran on.

    A shot saved during the run (from the editor, a text editor) can make a stage read the new shot
    while its parents were computed from the old one, or fail on the mix. When the sources changed
    during a round, the saved shot is validated like the first one (ShotError if it is bad) and the
    stages it touched run again; a failure is reported only if the shot did not change under it.
    Returns the shot the outputs belong to and {stage: {seconds, cached}} of what executed.
    """
    executed: dict[str, dict] = {}
    for _ in range(SETTLE_ROUNDS):
        p = plan(shot.root, settings, shot=shot)
        try:
            if p.to_run or not p.recorded:
                # an out-of-date Dagster instance (a new or deleted DAGSTER_HOME) re-records every stage: all cached
                executed.update(execute(p, settings, p.to_run or list(p.graph.stages), verbose, executor, outputs,
                                        on_computed))
                _remember_ui(p, p.graph.stages)
            failure = None
        except (StageFailed, ShotError) as e:
            failure = e
        now = load_shot(shot.root)  # a shot saved meanwhile: validated (ShotError if the saved one is bad)
        if source_versions(now) == p.sources:
            if failure is not None:
                raise failure
            return now, executed
        shot = now
    raise StageFailed(shot.root, "run", f"the shot was saved again during each of {SETTLE_ROUNDS} runs", None)


def evaluate_stages(shot_dir: str | Path, settings: Settings | None = None, verbose: bool = False) -> str:
    """Run a shot's evaluation group (after run_shot); returns its partition key."""
    settings = settings or Settings()
    shot = load_shot(shot_dir)
    partition = register(shot.root)
    with shot_lock(partition):
        p = plan(shot.root, settings, "evaluation", shot=shot)
        if p.to_run or not p.recorded:
            execute(p, settings, p.to_run or list(EVAL_STAGES), verbose)
            _remember_ui(p, EVAL_STAGES)
    return partition


def export_masks(shot_dir: str | Path, out_dir: str | Path, settings: Settings | None = None,
                 predicted: bool = False) -> list[Path]:
    """Write each keyframe's masks as manual masks accept them (docs/shot-format.md, `inbetween masks`):
    OUT/key{k}_foreground.png and OUT/key{k}_occlusion_{i}.png, 8-bit, 255 = inside, keyframe size.

    The occlusion masks are the refined ones the template is built from (after the T-junctions), unless
    `predicted`; runs only the mask stages that are not fresh.
    """
    from ops.shotio.image_io import write_image

    settings = settings or Settings()
    stage = "masks" if predicted else "refined_masks"
    shot = load_shot(shot_dir)
    names = tuple(f"key{k}/{n}" for k in range(shot.n_keys) for n in ("masks", "refined_masks"))
    partition = register(shot.root)
    with shot_lock(partition):
        p = plan(shot.root, settings, names, shot=shot)
        if p.to_run:
            execute(p, settings, p.to_run)
    out, written = Path(out_dir), []
    out.mkdir(parents=True, exist_ok=True)
    for k in range(shot.n_keys):
        masks = store().read(f"key{k}/{stage}", partition)
        written.append(write_image(out / f"key{k}_foreground.png", masks.foreground.astype(np.float32)))
        for i, region in enumerate(masks.occlusion):
            written.append(write_image(out / f"key{k}_occlusion_{i}.png", region.astype(np.float32)))
    return written
