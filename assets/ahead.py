"""Work-ahead: the stages of one in-process run computed on two threads as soon as their parents are.

Dagster's in-process executor runs one step after the other. Here every
selected stage of the run starts as soon as its parents have finished, on
one of two worker threads, while the executor's thread records the steps in
its own order: each step (assets/stage.py) waits for its stage's outcome,
replays its log lines, yields the output for the IO manager to store and runs
the checks. The worker that computed a stage also writes its output beside
its place in the store (Store.stage) once the stages below it may start, so
the IO manager only renames it into place; if that write fails, the IO
manager writes the output itself (and reports the failure, a full disk). The two keyframe lanes are independent up to rife_matrix; their heavy op
calls run in worker processes (assets/processes.py), so both cores work on them
while this process's GIL serves Dagster's event writes and the store's file
writes.

What stages of the run import or load when they start, and the Definitions
leave out so that a cold run starts computing sooner (the RIFE network, pandas
0.3 s), is prepared ahead too: on a thread of its own from the start when the
stages' op calls run in worker processes (assets/processes.py: the workers only
wait on them), else by a worker with no stage ready.

Outputs computed in the run stay in memory for the stages below them (no
read back from disk) until the run ends. Freshness is decided exactly as in
a step: from the parents' data versions, taken from this run's outcomes or
from the store, and the sources' versions as the plan observed them.
"""
from __future__ import annotations

import importlib
import logging
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from ops.settings import RecordingSettings, Settings
from ops.types import Shot
from resources.store import Store

from . import processes
from .compute import AHEAD, STAGE_SPECS, Outcome, StageEnv, run_stage
from .graph import shot_graph
from .stages import SHOT_STAGES  # noqa: F401  (declares every stage: STAGE_SPECS)

WORKERS = 2  # the machine's cores: a third thread would only contend
# while a run works ahead, a thread waiting for the GIL gets it after at most this long (Python's default: 5 ms).
# The main thread's Dagster bookkeeping is pure Python and holds the GIL for whole intervals; a stage's own Python
# between NumPy calls (a preview, a hash, a result read back) waited one interval per call: a textured template's
# 10 ms preview took 0.2 s. At 1 ms an edit of arm_cross's key1 ran its textured template and frames 0.15 s
# faster each (5 alternating runs).
GIL_SWITCH_S = 0.001
TABLE_KINDS = ("quality_metrics", "metrics")  # stages of these kinds build pandas tables


class _Log:
    """A compute function's log while it runs ahead of its step: kept, then replayed into the step's log."""

    def __init__(self):
        self.lines: list[tuple[int, str]] = []

    def log(self, level: int, message: str) -> None:
        self.lines.append((level, message))

    def debug(self, message: str) -> None:
        self.log(logging.DEBUG, message)

    def info(self, message: str) -> None:
        self.log(logging.INFO, message)

    def warning(self, message: str) -> None:
        self.log(logging.WARNING, message)

    def error(self, message: str) -> None:
        self.log(logging.ERROR, message)


class Resources:
    """The run's resources (the Definitions'), known from the start or given once the Dagster session is built:
    the run starts its stages first, and a stage that needs a resource before then waits for it
    (`context.resources.rife`, as on a Dagster context). Some may be given earlier (`provide_early`: the
    network and the inpainter, built as the Definitions build them once Dagster is imported): a stage that
    needs only those does not wait for the rest."""

    def __init__(self, values: dict[str, Any] | None = None):
        self._values: dict[str, Any] | None = None  # all of them, once given
        self._early: dict[str, Any] = {}
        self._error: BaseException | None = None
        self._changed = threading.Condition()
        if values is not None:
            self.provide(values)

    def provide(self, values: dict[str, Any]) -> None:
        with self._changed:
            self._values = dict(values)
            self._changed.notify_all()

    def provide_early(self, values: dict[str, Any]) -> None:
        """Some of the resources, the very objects the Definitions will bind, before the rest."""
        with self._changed:
            self._early.update(values)
            self._changed.notify_all()

    def fail(self, error: BaseException) -> None:
        """The session could not be built: a stage waiting for a resource fails with this."""
        with self._changed:
            self._error = error
            self._changed.notify_all()

    @property
    def known(self) -> dict[str, Any] | None:
        """The resources, if they have been given (None while pending)."""
        return self._values

    def get(self) -> dict[str, Any]:
        """All the resources, once given."""
        with self._changed:
            self._changed.wait_for(lambda: self._values is not None or self._error is not None)
        if self._values is None:
            raise RuntimeError(f"the run's resources were not built: {self._error}")
        return self._values

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        with self._changed:
            self._changed.wait_for(lambda: name in self._early or self._values is not None or self._error is not None)
            if name in self._early and self._values is None:
                return self._early[name]
        try:
            return self.get()[name]
        except KeyError:
            raise AttributeError(name) from None


class _Context:
    """What a compute function may use of its Dagster context while it runs ahead: resources and a log."""

    def __init__(self, resources: Resources):
        self.resources = resources
        self.log = _Log()


class WorkAhead:
    """The selected stages of one partition's run, computed ahead of their steps on WORKERS threads."""

    def __init__(self, partition: str, names: list[str], shot: Shot, sources: dict[str, str], settings: Settings,
                 store: Store, resources: dict[str, Any] | Resources, workers: int = WORKERS, parallel: bool = False,
                 on_computed: Callable[[str, str, Any], None] | None = None):
        """resources: the run's, or a Resources given later; parallel: the stages' op calls run in worker
        processes (assets/processes.py), whose pool is started; on_computed(stage, data version, output): called
        on the computing thread as soon as a stage has computed a new output (it must return quickly)."""
        resources = resources if isinstance(resources, Resources) else Resources(resources)
        self.partition, self.names, self.shot, self.sources = partition, set(names), shot, sources
        self.settings, self.store, self.resources = settings, store, resources
        self.graph = shot_graph(shot.n_keys)
        self.order = [n for n in self.graph.all_stages if n in self.names]  # parents first
        self.state = {n: "pending" for n in self.order}  # pending | running | done | failed
        self.outcomes: dict[str, Outcome] = {}
        self.errors: dict[str, BaseException] = {}
        self.settled: set[str] = set()  # done, and its new output (if any) written beside its place
        self.unwritten: list[str] = []  # done, its new output not yet written beside its place (the writer's queue)
        self.memory: dict[str, Any] = {}  # outputs computed in this run
        self.contexts: dict[str, _Context] = {}
        self.urgent: str | None = None  # the stage a step waits for: picked first
        self.warm_up = _warm_ups(self.order, resources)  # for a worker with no stage ready, in this order
        self.closed = False
        self.parallel = parallel
        self.on_computed = on_computed
        self.cond = threading.Condition()
        self.threads = [threading.Thread(target=self._work, name=f"inbetween-ahead-{i}", daemon=True)
                        for i in range(workers)]
        # the outputs are written beside their places on a thread of their own: a worker that finished a stage
        # starts the next one at once (the matrix's 94 MB took a worker 0.2 s, and the shot's frames waited)
        self.threads.append(threading.Thread(target=self._write, name="inbetween-ahead-writer", daemon=True))
        if self.parallel:  # the workers only wait on processes: the warm-ups get a thread of their own, now
            jobs, self.warm_up = self.warm_up, []
            self.threads.append(threading.Thread(target=lambda: [_prepare(job) for job in jobs], daemon=True,
                                                 name="inbetween-ahead-warm-up"))

    # ---- the executor's side

    def outcome(self, name: str, context: Any) -> tuple[Outcome, StageEnv]:
        """Wait for stage `name` (computing it here if no worker has started it); replay its log into the step's
        context; -> (outcome, env for the checks). Re-raises the stage's exception."""
        with self.cond:
            if self.state[name] == "pending" and self._ready(name):
                self.state[name] = "running"  # the executor's thread is idle anyway: compute here
                inline = True
            else:
                inline = False
                self.urgent = name
                self.cond.notify_all()
                while self.state[name] != "failed" and name not in self.settled:
                    self.cond.wait()
        if inline:
            self._compute(name)
            with self.cond:  # its output is written beside its place by the writer, as every other's
                while self.state[name] != "failed" and name not in self.settled:
                    self.cond.wait()
        for level, message in self.contexts[name].log.lines:
            context.log.log(level, message)
        if name in self.errors:
            raise self.errors[name]
        return self.outcomes[name], self._env(name, context)

    # ---- the workers' side

    def _ready(self, name: str) -> bool:
        return all(self.state.get(p, "done") == "done" for p in self.graph.parents[name])

    def _next(self) -> str | None:
        """A pending stage whose parents are done (the one a step waits for first), or None."""
        ready = [n for n in self.order if self.state[n] == "pending" and self._ready(n)]
        if self.urgent in ready:
            return self.urgent
        return ready[0] if ready else None

    def _work(self) -> None:
        while True:
            with self.cond:
                while not self.closed and (name := self._next()) is None and not self.warm_up:
                    self.cond.wait()
                if self.closed:
                    return
                if name is None:
                    job = self.warm_up.pop(0)
                else:
                    self.state[name] = "running"
            if name is None:
                _prepare(job)
            else:
                self._compute(name)

    def _compute(self, name: str) -> None:
        context = self.contexts[name] = _Context(self.resources)
        env = self._env(name, context)
        try:
            parents = {p: self.sources[p] if p in self.sources else self._version(p) for p in self.graph.parents[name]}
            outcome = run_stage(name, env, parents, self.settings)
        except BaseException as e:  # the step re-raises it, with this traceback
            with self.cond:
                self.errors[name] = e
                self.state[name] = "failed"
                self.cond.notify_all()
            return
        with self.cond:
            self.outcomes[name] = outcome
            if not outcome.cached:
                self.memory[name] = outcome.result.value
            self.state[name] = "done"  # the stages below it may start
            self.unwritten.append(name)
            self.cond.notify_all()
        if self.on_computed is not None and not outcome.cached:
            try:
                self.on_computed(name, outcome.version, outcome.result.value)
            except Exception:  # noqa: BLE001  (a listener's failure is its own: the run goes on without it)
                pass

    def _write(self) -> None:
        """The writer thread: each new output beside its place in the store, in the order the stages finished."""
        while True:
            with self.cond:
                while not self.closed and not self.unwritten:
                    self.cond.wait()
                if self.closed:
                    return
                name = self.unwritten.pop(0)
            outcome = self.outcomes[name]
            if not outcome.cached:
                try:
                    self.store.stage(name, self.partition, outcome.result.value, outcome.version, outcome.record)
                except Exception:  # noqa: BLE001  (the step's IO manager writes it, and reports the failure)
                    pass
            with self.cond:
                self.settled.add(name)
                self.cond.notify_all()
                if self.closed:  # the run ended without its step: nothing renames it into place
                    self.store.discard(name, self.partition)

    def _version(self, name: str) -> str | None:
        """Data version of a stage: this run's outcome if it ran here, else the stored output's."""
        outcome = self.outcomes.get(name)
        return outcome.version if outcome is not None else self.store.hash(name, self.partition)

    def _env(self, name: str, context: Any) -> StageEnv:
        env = StageEnv(context, self.partition, self.store, None, RecordingSettings(self.settings), self.memory, name)
        env.__dict__["shot"] = self.shot  # the plan's shot: loaded once per run
        env.parallel = self.parallel
        return env

    def start(self) -> None:
        for t in self.threads:
            t.start()

    def close(self) -> None:
        """Stop scheduling; a stage already computing finishes on its daemon thread and is dropped, and so is
        every output written ahead that no step put into place."""
        with self.cond:
            self.closed = True
            self.cond.notify_all()
        for name in self.order:
            self.store.discard(name, self.partition)


def _warm_ups(stages: list[str], resources: Resources) -> list[Callable[[], Any]]:
    """What the stages of a run will import or load when they start, and the Definitions did not."""
    jobs: list[Callable[[], Any]] = []
    known = resources.known  # pending: the Definitions' resources, which always hold the network
    if (known is None or "rife" in known) and any("rife" in getattr(STAGE_SPECS.get(n), "resources", ())
                                                  for n in stages):
        jobs.append(lambda: resources.rife.load())  # cached per process: the stage gets the loaded network
    if any(n.rsplit("/", 1)[-1] in TABLE_KINDS for n in stages):
        jobs.append(lambda: importlib.import_module("pandas"))
    return jobs


def _prepare(job: Callable[[], Any]) -> None:
    try:
        job()
    except Exception:  # noqa: BLE001  (the stage that needs it does it again, and reports the error)
        pass


@contextmanager
def working_ahead(partition: str, names: list[str], shot: Shot, sources: dict[str, str], settings: Settings,
                  store: Store, resources: dict[str, Any] | Resources,
                  on_computed: Callable[[str, str, Any], None] | None = None) -> Iterator[WorkAhead]:
    """While open, the steps of `names` for this partition in this process take their outcomes from a WorkAhead
    (on_computed: WorkAhead's)."""
    parallel = processes.pool() is not None  # started now: its imports overlap Dagster's start
    ahead = WorkAhead(partition, names, shot, sources, settings, store, resources, parallel=parallel,
                      on_computed=on_computed)
    AHEAD[partition] = ahead
    switch = sys.getswitchinterval()
    sys.setswitchinterval(min(switch, GIL_SWITCH_S))
    ahead.start()
    try:
        yield ahead
    finally:
        ahead.close()
        AHEAD.pop(partition, None)
        sys.setswitchinterval(switch)
