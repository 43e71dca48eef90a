"""The run machinery beneath every front end: the CLI, `inbetween eval`, the editor and the farm call this.

- `plan`: the status of every stage of a shot (fresh, stale with causes, or
  missing), decided from the shot files and the store alone: no Dagster, no
  torch (assets/provenance.py).
- `run_shot`: validate the shot, take its partition's lock (a second run of
  the same shot waits, and says so), plan, run the stages that are not fresh
  in one in-process Dagster execution, and write the frames and report.
  When every stage is fresh and the Dagster instance already records the
  current versions, Dagster is not started at all.
- `batch`, `status`, `evaluate_stages`.

Front ends only parse, call and print.

Hardening (issue 10): a shot saved while it runs is run again on what was saved
(`_settle`); SQLite's "database is locked" from another process writing the
Dagster instance is retried, never shown (`retry_database_locked`); a deleted
Dagster home gets a fresh instance even in a long-lived process; a damaged one
is one line with its fix (`HomeDamaged`); a batch worker that dies is one failed
shot, not a traceback; Python warnings go to INBETWEEN_HOME/logs/warnings.log.
"""
from __future__ import annotations

import fcntl
import functools
import json
import os
import random
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass, field
from multiprocessing import context as mp_context
from pathlib import Path

import numpy as np

from ops.errors import ShotError
from ops.settings import Settings
from ops.shotio.load import check_batch, load_shot
from ops.shotio.versions import source_versions
from ops.types import Shot
from resources.registry import register_shot
from resources.store import Store

from . import progress
from .codeversion import ROOT, project_fingerprint
from .graph import EVAL_STAGES, SOURCES, STAGES
from .home import ensure_home, home, instance_id
from .provenance import StageStatus, resolve, to_run

SHOT_STAGES = STAGES


class RelayedShotError(ShotError):
    """A ShotError raised inside a stage, relayed from its step with its one-line message unchanged."""

    def __init__(self, message: str):
        ValueError.__init__(self, message)
        self.file, self.field, self.problem, self.fix = "", "", message, ""


# what to try when a stage of this kind fails (the cause says what went wrong)
FIXES = {
    "masks": "check the keyframe image and its pose, or paint masks.foreground (see `inbetween masks`)",
    "refined_masks": "check this keyframe's T-junction clicks, or paint masks.occlusion",
    "template": "check that the key poses' joints lie on the drawing, or paint masks.foreground / masks.occlusion",
    "textured_template": "check the key poses' depths (z) and the occlusion masks",
    "deformed_frames": "check the in-between poses (a bone folding through itself, a joint far off the drawing)",
    "rife_matrix": "check INBETWEEN_DEVICE and the RIFE weights",
}
GENERIC_FIX = "rerun with --debug for the full trace, or see the log"


class StageFailed(RuntimeError):
    """A stage raised: one line naming the shot, the stage, the cause and a fix; the full trace is in the log."""

    def __init__(self, shot: str, stage: str, cause: str, log: Path | None, trace: str = "", fix: str | None = None):
        self.shot, self.stage, self.cause, self.log, self.trace = shot, stage, cause, log, trace
        cause = " ".join(cause.split())  # one line, whatever the exception's message held
        full = any(sign in cause for sign in DISK_FULL_SIGNS)
        fix = fix or (DISK_FULL_FIX if full else FIXES.get(stage.split("/")[-1], GENERIC_FIX))
        super().__init__(f"{shot}: {stage}: {cause}; fix: {fix}")


class RunInterrupted(StageFailed):
    """The run was stopped (Ctrl-C, SIGTERM from `timeout` or a scheduler) while a stage computed: not the stage's
    fault, so not its fix."""

    def __init__(self, shot: str, stage: str, log: Path | None, trace: str = ""):
        super().__init__(shot, stage, "interrupted (SIGINT or SIGTERM)", log, trace,
                         fix="rerun: the stages already stored are kept, and the run goes on from them")


INTERRUPTIONS = ("DagsterExecutionInterruptedError", "KeyboardInterrupt")  # how Dagster reports SIGINT / SIGTERM

DISK_FULL_FIX = "free disk space under INBETWEEN_HOME and the output folder, then rerun (stored stages are kept)"
DISK_FULL_SIGNS = ("No space left on device", "database or disk is full")  # OSError ENOSPC; SQLite's SQLITE_FULL


class HomeDamaged(RuntimeError):
    """The Dagster home cannot be opened (a damaged dagster.yaml or SQLite file): one line with its fix."""

    def __init__(self, path: Path, cause: BaseException):
        self.path = path
        text = " ".join(str(cause).split())[:200]
        super().__init__(f"{path}: the Dagster instance cannot be opened ({type(cause).__name__}: {text}); "
                         f"fix: remove {path} (stage outputs stay in INBETWEEN_HOME/storage; only the UI's "
                         f"run history is lost) and rerun")


class ShotFailure(str):
    """One failed shot of a batch: its one-line message (a str, as batch() always returned) plus the shot's
    name and whether its input was bad (exit 2) or a stage failed (exit 1)."""

    shot: str
    bad_input: bool

    def __new__(cls, message: str, shot: str, bad_input: bool):
        self = super().__new__(cls, message)
        self.shot, self.bad_input = shot, bad_input
        return self

    def __reduce__(self):  # crosses the process pool's pipe
        return ShotFailure, (str(self), self.shot, self.bad_input)


# ---------------------------------------------------------------- planning (no Dagster)


def code_records() -> dict[str, dict[str, str]]:
    """Code record of every stage. Cached in INBETWEEN_HOME keyed by a hash of the project's sources, so the
    planner needs Dagster (to import the stage definitions) only after the code changed.

    A process that imported the definitions before the sources changed on disk (a long-lived server)
    holds the old functions: it asks a fresh interpreter for the records of the code as it is now.
    """
    cache = home() / "code_records.json"
    fingerprint = project_fingerprint()
    try:
        data = json.loads(cache.read_text())
        if data.get("fingerprint") == fingerprint:
            return data["records"]
    except (OSError, ValueError):
        pass
    loaded = sys.modules.get("assets.definitions")
    if loaded is not None and loaded.LOADED_FINGERPRINT != fingerprint:
        out = subprocess.run([sys.executable, "-c", "import json; from assets.runs import _import_code_records; "
                              "print(json.dumps(_import_code_records()))"],
                             capture_output=True, text=True, check=True, cwd=ROOT)
        records = json.loads(out.stdout.strip().splitlines()[-1])
    else:
        records = _import_code_records()
    cache.parent.mkdir(parents=True, exist_ok=True)
    tmp = cache.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(json.dumps({"fingerprint": fingerprint, "records": records}))
    os.replace(tmp, cache)
    return records


def _import_code_records() -> dict[str, dict[str, str]]:
    _quiet_dagster_warnings()
    from . import definitions  # noqa: F401  (defining the assets fills STAGE_SPECS)
    from .stage import STAGE_SPECS

    return {name: spec.code for name, spec in STAGE_SPECS.items()}


@dataclass
class Plan:
    """What a run of one shot would do."""

    shot: Shot
    partition: str
    sources: dict[str, str]  # source asset -> data version (content hash)
    statuses: dict[str, StageStatus]  # stage -> status
    recorded: bool  # the Dagster instance already records exactly these versions (the UI is current)

    @property
    def to_run(self) -> list[str]:
        return to_run(self.statuses)


def store() -> Store:
    return Store(home() / "storage")


def register(shot_dir: str | Path) -> str:
    """Partition key of a shot directory (registered on first use)."""
    return register_shot(home() / "shots.json", shot_dir)


def _ui_record_path(partition: str) -> Path:
    return store().root / partition / "dagster.json"


def plan(shot_dir: str | Path, settings: Settings | None = None, stages: tuple[str, ...] = SHOT_STAGES,
         shot: Shot | None = None) -> Plan:
    """Validate the shot and decide the status of each of `stages` (ShotError on bad input)."""
    shot = shot or load_shot(shot_dir)
    partition = register(shot.root)
    sources = source_versions(shot)
    st = store()
    statuses = resolve(partition, st, sources, settings or Settings(), code_records(), stages)
    try:
        ui = json.loads(_ui_record_path(partition).read_text())
    except (OSError, ValueError):
        ui = {}
    current = {"instance": instance_id(), "sources": sources,
               "stages": {n: st.hash(n, partition) for n in stages}}
    recorded = (current["instance"] is not None and ui.get("instance") == current["instance"]
                and ui.get("sources") == sources
                and all(ui.get("stages", {}).get(n) == v for n, v in current["stages"].items()))
    return Plan(shot, partition, sources, statuses, recorded)


def _remember_ui(p: Plan, stages: tuple[str, ...]) -> None:
    """Note what the Dagster instance now records for this partition (so an unchanged rerun needs no Dagster)."""
    st = store()
    path = _ui_record_path(p.partition)
    try:
        ui = json.loads(path.read_text())
    except (OSError, ValueError):
        ui = {}
    if ui.get("instance") != instance_id():
        ui = {}
    ui.update({"instance": instance_id(), "sources": p.sources})
    ui.setdefault("stages", {}).update({n: st.hash(n, p.partition) for n in stages})
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(json.dumps(ui))
    os.replace(tmp, path)


@contextmanager
def shot_lock(partition: str, on_wait: Callable[[], None] | None = None) -> Iterator[None]:
    """Exclusive lock of one shot partition across processes; calls on_wait() once if another run holds it."""
    path = home() / "locks" / f"{partition}.lock"
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if on_wait:
                on_wait()
            fcntl.flock(f, fcntl.LOCK_EX)
        yield


# ---------------------------------------------------------------- executing (Dagster)


def _quiet_dagster_warnings() -> None:
    import dagster as dg

    for category in (dg.BetaWarning, dg.PreviewWarning, getattr(dg, "ExperimentalWarning", None)):
        if category is not None:
            warnings.filterwarnings("ignore", category=category)


def warnings_to_log() -> Path:
    """Send every Python warning of this process to INBETWEEN_HOME/logs/warnings.log instead of stderr.

    Dagster's Beta/Preview warnings, a library's DeprecationWarning, numpy's RuntimeWarning on odd input:
    none is the user's business on the terminal (--verbose leaves them there).
    """
    path = home() / "logs" / "warnings.log"

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            with open(path, "a") as f:
                f.write(f"{time.strftime('%Y-%m-%d %H:%M:%S')} {os.getpid()} "
                        f"{warnings.formatwarning(message, category, filename, lineno, line).rstrip()}\n")
        except OSError:
            pass  # a warning never fails a run

    warnings.showwarning = show
    return path


def _database_locked(e: BaseException | None) -> bool:
    """True when SQLite's "database is locked" is anywhere in the exception, its chain or its stage's trace."""
    seen = 0
    while e is not None and seen < 20:
        if "database is locked" in f"{e} {getattr(e, 'trace', '')}":
            return True
        e, seen = e.__cause__ or e.__context__, seen + 1
    return False


LOCKED_ATTEMPTS = 6


def retry_database_locked(fn):
    """Retry `fn` when another process holds the SQLite Dagster instance locked longer than SQLite waits.

    With backoff (about 0.5, 1, 2, 4, 8 s, jittered so two waiting processes do not collide again).
    Safe to repeat: stages stored by a failed attempt are fresh on the next one, and are not run again.
    """
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        for attempt in range(LOCKED_ATTEMPTS):
            try:
                return fn(*args, **kwargs)
            except Exception as e:
                if attempt == LOCKED_ATTEMPTS - 1 or not _database_locked(e):
                    raise
                time.sleep(min(8.0, 0.5 * 2**attempt) * (0.5 + random.random()))
        raise AssertionError("unreachable")

    return wrapper


class Session:
    """The Dagster instance and the Definitions, built once per process per (settings, home).

    The instance is opened on first use (`instance`): a run starts computing its stages (assets/ahead.py)
    while it opens, which on a new home creates its SQLite tables.
    """

    _cache: dict[tuple, Session] = {}

    def __init__(self, settings: Settings):
        ensure_home()
        _quiet_dagster_warnings()
        import dagster as dg

        from . import definitions

        self.dg = dg
        self.settings = settings
        # the module's Definitions (the UI's) serve the default settings while the home and shots root they were
        # built for are still this process's (a test, the editor, may change them): built once per process
        self.defs = (definitions.defs if settings == Settings() and definitions.built_for() == definitions.current_place()
                     else definitions.build_definitions(settings))
        self.resources = dict(self.defs.resources)
        self.job = self.defs.resolve_implicit_global_asset_job_def()
        self._instance = None

    @property
    def instance(self):
        if self._instance is None:  # not kept when opening fails: the next call tries again
            self._instance = open_instance()
        return self._instance

    @classmethod
    def get(cls, settings: Settings) -> Session:
        ensure_home()
        # the instance id changes when the Dagster home was deleted: a cached instance would write into
        # SQLite files that no longer exist, so a long-lived process (the editor) opens the new home
        key = (settings, home(), os.environ.get("DAGSTER_HOME"), os.environ.get("INBETWEEN_SHOTS"), instance_id())
        if key not in cls._cache:
            cls._cache[key] = cls(settings)
        return cls._cache[key]

    def ensure_partition(self, partition: str) -> None:
        if not self.instance.has_dynamic_partition("shots", partition):
            self.instance.add_dynamic_partitions("shots", [partition])

    def observe(self, partition: str, sources: dict[str, str]) -> None:
        """Record the sources' data versions as observations (no run is launched)."""
        from .stage import asset_key

        for name in SOURCES:
            self.instance.report_runless_asset_event(self.dg.AssetObservation(
                asset_key=asset_key(name), partition=partition, tags={"dagster/data_version": sources[name]}))

    def materialize(self, shot: str, partition: str, names: list[str], log_path: Path, verbose: bool = False):
        """Run the named stages of one partition in one in-process execution; StageFailed if a stage raises."""
        from .stage import asset_key

        run_config = {"loggers": {"file": {"config": {"path": str(log_path)}},
                                  "console": {"config": {"log_level": "DEBUG" if verbose else "CRITICAL"}}}}
        result = self.job.execute_in_process(
            instance=self.instance, partition_key=partition, asset_selection=[asset_key(n) for n in names],
            run_config=run_config, raise_on_error=False, tags={"inbetween/shot": partition})
        if not result.success:
            raise_failure(result.all_events, shot, log_path)
        return result

    def materialize_farm(self, shot: str, partition: str, names: list[str], log_path: Path, verbose: bool = False):
        """Run the named stages of one partition as one run of the farm job: each step on a Celery worker
        (assets/farm/), this process orchestrating; StageFailed if a stage raises."""
        from .definitions import farm_job, resources_config
        from .stage import asset_key

        run_config = {"loggers": {"file": {"config": {"path": str(log_path)}},
                                  "console": {"config": {"log_level": "DEBUG" if verbose else "CRITICAL"}}},
                      "resources": resources_config(self.settings)}
        result = self.dg.execute_job(
            self.dg.reconstructable(farm_job), self.instance, run_config=run_config,
            tags={"inbetween/shot": partition, "dagster/partition": partition},
            asset_selection=[asset_key(n) for n in names])
        if not result.success:
            raise_failure(result.all_events, shot, log_path)
        return result


def raise_failure(events, shot: str, log_path: Path):
    """The one-line error of a failed run: a ShotError raised inside a stage as it was, else StageFailed."""
    failures = [e for e in events if e.event_type_value == "STEP_FAILURE"]
    if failures:
        ev = failures[0]
        err = ev.event_specific_data.error
        stage = ev.step_key.replace("__", "/")
        chain = [err]
        while chain[-1].cause is not None:
            chain.append(chain[-1].cause)
        for e in chain:  # bad input found inside a stage: the same one-line error as at loading
            if e.cls_name == "ShotError":
                text = e.message.strip().splitlines()[-1]
                raise RelayedShotError(text.split("ShotError: ", 1)[-1])
        if any(e.cls_name in INTERRUPTIONS for e in chain):
            raise RunInterrupted(shot, stage, log_path, err.to_string())
        cause = chain[-1]
        lines = cause.message.strip().splitlines()
        text = lines[0] if lines else "failed"
        raise StageFailed(shot, stage, text if text.startswith(cause.cls_name) else f"{cause.cls_name}: {text}",
                          log_path, err.to_string())
    cause = _run_failure_cause(events)
    if cause.split(":", 1)[0] in INTERRUPTIONS:
        raise RunInterrupted(shot, "run", log_path)
    raise StageFailed(shot, "run", cause, log_path)


def open_instance():
    """The Dagster instance of DAGSTER_HOME; HomeDamaged (one line, with the fix) when it cannot be opened."""
    import dagster as dg

    from .home import dagster_home

    lock = home() / "locks" / "dagster-instance.lock"
    lock.parent.mkdir(parents=True, exist_ok=True)
    try:
        # one process at a time: two processes opening a new SQLite home both create its tables, and the
        # second fails with "table jobs already exists" (batch workers starting on a fresh home)
        with open(lock, "w") as f:
            fcntl.flock(f, fcntl.LOCK_EX)
            instance = dg.DagsterInstance.get()
            instance.get_runs_count()  # opens the run storage: a damaged SQLite file fails here, not mid-run
        return instance
    except Exception as e:
        if _database_locked(e):
            raise
        raise HomeDamaged(dagster_home(), e) from e


def _run_failure_cause(events) -> str:
    """The first error a failed run reports outside any step (a resource that did not start, the engine)."""
    for ev in events:
        err = getattr(ev.event_specific_data, "error", None)
        if err is not None:
            while err.cause is not None:
                err = err.cause
            lines = err.message.strip().splitlines()
            return f"{err.cls_name}: {lines[0] if lines else 'failed'}"
    return "the Dagster run failed"


# ---------------------------------------------------------------- front-end calls


@dataclass
class RunReport:
    """Outcome of run_shot: the report.json contents plus what the front end may print."""

    data: dict
    waited: bool = False
    events: list[dict] = field(default_factory=list)


def _log_path(partition: str) -> Path:
    return home() / "logs" / f"{time.strftime('%Y%m%d-%H%M%S')}-{partition}-{os.getpid()}.log"


EXECUTORS = ("in_process", "celery")  # celery: every step on a farm worker (assets/farm/, docs/production.md)


@retry_database_locked
def execute(p: Plan, settings: Settings, names: list[str], verbose: bool = False,
            executor: str = "in_process") -> dict[str, dict]:
    """Run `names` (plus everything needed to make the Dagster UI current); {stage: {seconds, cached}}."""
    from .ahead import working_ahead

    session = Session.get(settings)
    if executor == "celery":
        session.ensure_partition(p.partition)
        session.observe(p.partition, p.sources)
        result = session.materialize_farm(p.shot.root, p.partition, names, _log_path(p.partition), verbose)
        return stage_timings(result.all_events)
    executed: dict[str, dict] = {}

    def on_event(ev: dict) -> None:
        if ev["event"] == "done" and ev["partition"] == p.partition:
            executed[ev["stage"]] = {"seconds": ev["seconds"], "cached": ev["cached"]}

    # the stages compute on two threads as soon as their parents have, ahead of the steps that record them
    # (from before the instance opens: their outputs are stored and recorded by their steps alone);
    # the sources' versions are the ones the plan observed (not hashed again per step)
    with progress.listen(on_event), working_ahead(p.partition, names, p.shot, p.sources, settings, store(),
                                                  session.resources):
        session.ensure_partition(p.partition)
        session.observe(p.partition, p.sources)
        session.materialize(p.shot.root, p.partition, names, _log_path(p.partition), verbose)
    return executed


def stage_timings(events) -> dict[str, dict]:
    """{stage: {seconds, cached}} from a run's materializations (steps that ran in other processes)."""
    out = {}
    for ev in events:
        if ev.event_type_value == "ASSET_MATERIALIZATION":
            mat = ev.event_specific_data.materialization
            meta = {k: getattr(v, "value", v) for k, v in mat.metadata.items()}
            out["/".join(mat.asset_key.path)] = {"seconds": meta.get("seconds", 0.0), "cached": meta.get("cached", False)}
    return out


def run_shot(shot_dir: str | Path, out_dir: str | Path, settings: Settings | None = None, *,
             on_wait: Callable[[], None] | None = None, verbose: bool = False, executor: str = "in_process") -> dict:
    """Run one shot end to end; returns the report (also written to OUT_DIR/report.json).

    executor: "in_process" (this process runs the stages) or "celery" (farm workers do; this process waits).
    """
    from ops.shotio.frames import write_outputs

    start = time.perf_counter()
    settings = settings or Settings()
    shot = load_shot(shot_dir)  # validate before touching anything
    partition = register(shot.root)
    with shot_lock(partition, on_wait):
        shot, executed = _settle(shot, settings, verbose, executor)
        st = store()
        frames = st.read("inbetween_frames", partition)
        paths = st.read("optimal_path", partition)
        repairs = stage_warnings(partition)
    stages = {n: {"executed": n in executed, **executed.get(n, {"seconds": 0.0, "cached": True}),
                  "warnings": repairs.get(n, 0)} for n in SHOT_STAGES}
    chosen = paths.optimal if settings.blend == "optimal" else paths.diagonal
    report = {"shot": shot.root, "partition": partition, "frames": int(len(frames.times)),
              "times": [float(t) for t in frames.times], "alphas": [float(a) for a in frames.alphas],
              "blend": settings.blend, "template": settings.template_mode, "stages": stages,
              "frames_version": st.hash("inbetween_frames", partition),
              "path": {"cost": float(chosen.cost), "cost_optimal": float(paths.optimal.cost),
                       "cost_diagonal": float(paths.diagonal.cost),
                       "abrupt_transitions": [[float(paths.times[i]), float(paths.times[i + 1])]
                                              for i in range(len(chosen.abrupt)) if chosen.abrupt[i]]}}
    report["seconds_total"] = round(time.perf_counter() - start, 3)
    write_outputs(Path(out_dir), frames.frames, report)
    return report


SETTLE_ROUNDS = 3


def _settle(shot: Shot, settings: Settings, verbose: bool, executor: str = "in_process"
            ) -> tuple[Shot, dict[str, dict]]:
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
                executed.update(execute(p, settings, p.to_run or list(SHOT_STAGES), verbose, executor))
                _remember_ui(p, SHOT_STAGES)
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


def stage_warnings(partition: str, names: tuple[str, ...] = SHOT_STAGES) -> dict[str, int]:
    """How many input repairs (warnings) each stored stage recorded: {stage: count}, stages without any left out."""
    st = store()
    out = {}
    for name in names:
        _, recorded = st.provenance(name, partition)
        n = len((recorded or {}).get("warnings") or [])
        if n:
            out[name] = n
    return out


def status(shot_dir: str | Path, settings: Settings | None = None) -> Plan:
    """The plan of a shot: which stages the next run executes, and why."""
    return plan(shot_dir, settings)


def evaluate_stages(shot_dir: str | Path, settings: Settings | None = None, verbose: bool = False) -> str:
    """Run a shot's evaluation group (after run_shot); returns its partition key."""
    settings = settings or Settings()
    shot = load_shot(shot_dir)
    partition = register(shot.root)
    with shot_lock(partition):
        p = plan(shot.root, settings, EVAL_STAGES, shot=shot)
        if p.to_run or not p.recorded:
            execute(p, settings, p.to_run or list(EVAL_STAGES), verbose)
            _remember_ui(p, EVAL_STAGES)
    return partition


def export_masks(shot_dir: str | Path, out_dir: str | Path, settings: Settings | None = None,
                 predicted: bool = False) -> list[Path]:
    """Write each keyframe's masks as manual masks accept them (SHOT_FORMAT.md `inbetween masks`):
    OUT/key{k}_foreground.png and OUT/key{k}_occlusion_{i}.png, 8-bit, 255 = inside, keyframe size.

    The occlusion masks are the refined ones the template is built from (after the T-junctions), unless
    `predicted`; runs only the mask stages that are not fresh.
    """
    from ops.shotio.image_io import write_image

    settings = settings or Settings()
    stage = "masks" if predicted else "refined_masks"
    names = tuple(f"key{k}/{n}" for k in (0, 1) for n in ("masks", "refined_masks"))
    shot = load_shot(shot_dir)
    partition = register(shot.root)
    with shot_lock(partition):
        p = plan(shot.root, settings, names, shot=shot)
        if p.to_run:
            execute(p, settings, p.to_run)
    out, written = Path(out_dir), []
    out.mkdir(parents=True, exist_ok=True)
    for k in (0, 1):
        masks = store().read(f"key{k}/{stage}", partition)
        written.append(write_image(out / f"key{k}_foreground.png", masks.foreground.astype(np.float32)))
        for i, region in enumerate(masks.occlusion):
            written.append(write_image(out / f"key{k}_occlusion_{i}.png", region.astype(np.float32)))
    return written


def _batch_worker(shot_dir: str, out_dir: str, settings: Settings,
                  verbose: bool = False, executor: str = "in_process") -> tuple[str, dict | None, ShotFailure | None]:
    import torch

    if not verbose:
        warnings_to_log()
    torch.set_num_threads(1)  # two shots share two cores
    name = Path(shot_dir).name
    try:
        return shot_dir, run_shot(shot_dir, out_dir, settings, verbose=verbose, executor=executor), None
    except ShotError as e:
        return shot_dir, None, ShotFailure(str(e), name, True)
    except (StageFailed, HomeDamaged) as e:
        return shot_dir, None, ShotFailure(str(e), name, False)
    except Exception as e:  # one line per failed shot; other shots go on
        cause = " ".join(f"{type(e).__name__}: {e}".split())[:300]
        return shot_dir, None, ShotFailure(f"{shot_dir}: {cause}", name, False)


def exit_without_teardown(code: int, run_atexit: bool = True) -> None:
    """Exit with `code` now, skipping the interpreter's finalization: tearing down every module and object a
    run loaded (torch, Dagster, SQLAlchemy) takes 0.5 s and does nothing for us once the outputs are written.
    The atexit handlers run first (logging flushes its files) unless `run_atexit` is False; then the standard
    streams are flushed."""
    import atexit
    import logging

    if run_atexit:
        getattr(atexit, "_run_exitfuncs", logging.shutdown)()  # CPython's; else at least the logs are flushed
    else:
        logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)


class _LeavingProcess(mp_context.SpawnProcess):
    """A batch worker that, once its shot is run and its result sent (a synchronous pipe write), exits without
    finalizing its interpreter (exit_without_teardown: 0.5 s a shot); a worker that raised exits as usual."""

    def run(self) -> None:
        super().run()
        exit_without_teardown(0)


class _LeavingContext(mp_context.SpawnContext):
    Process = _LeavingProcess


def batch(root: str | Path, out_dir: str | Path, workers: int = 2, settings: Settings | None = None,
          verbose: bool = False, on_done: Callable[[str, dict | None, ShotFailure | None], None] | None = None,
          executor: str = "in_process") -> tuple[dict, list[str]]:
    """Every shot directory under root, `workers` at a time; returns (reports by shot name, errors).

    Each error is a ShotFailure (a str naming the shot's failure in one line). on_done(shot name, report,
    error) is called as each shot ends. A batch whose valid shots together exceed the output-pixel bound
    is refused before any shot runs (ShotError).

    executor "celery": each shot is one run of the farm job whose steps run on Celery workers; `workers` is
    then how many shots are in flight (each an orchestrating process that mostly waits).
    """
    if executor not in EXECUTORS:
        raise ValueError(f"executor must be one of {EXECUTORS}, got {executor!r}")

    settings = settings or Settings()
    ensure_home()
    shots = sorted(d for d in Path(root).iterdir() if (d / "shot.json").is_file())
    valid = []
    for d in shots:
        try:
            valid.append(load_shot(d))
        except ShotError:
            pass  # its worker reports it, and the other shots go on
    check_batch(root, valid)
    for d in shots:  # register up front, one writer at a time
        register(d)
    reports, errors = {}, []
    # one fresh process per shot: a worker that ran shot after shot kept every one's leftovers (allocator
    # arenas, caches), and its peak RSS grew with the batch (1.77 GB over the 12 samples, one shot 1.2 GB)
    with ProcessPoolExecutor(max_workers=max(1, workers), mp_context=_LeavingContext(),
                             max_tasks_per_child=1) as pool:
        futures = {pool.submit(_batch_worker, str(d), str(Path(out_dir) / d.name), settings, verbose,
                               executor): d
                   for d in shots}
        for f in as_completed(futures):
            try:
                shot_dir, report, error = f.result()
            except BrokenProcessPool:  # a worker died (killed, out of memory): its shot failed, not the batch
                d = futures[f]
                shot_dir, report = str(d), None
                error = ShotFailure(f"{d}: run: the worker process died (killed, or out of memory); fix: rerun the "
                                    "batch (stored stages are kept); if it dies again, run this shot alone with "
                                    "`inbetween run`", d.name, False)
            if error:
                errors.append(error)
            else:
                reports[Path(shot_dir).name] = report
            if on_done is not None:
                on_done(Path(shot_dir).name, report, error)
    return reports, errors
