"""`inbetween worker`: a Celery worker running dagster-celery's step task, with our Definitions preloaded.

A thin layer over dagster-celery's worker (`dagster-celery worker start`): the
same task (`execute_plan`: rebuild the job from its module, run one step
against the run's Dagster instance, return its events), on an app built from
the farm's shared settings (settings.py), listening on `cpu`, `gpu` or both.

concurrency 1 runs steps in the worker process itself (Celery's solo pool):
the Definitions and the RIFE network load once, and killing the process
kills the step. concurrency N > 1 forks N children (prefork), one step each.
"""
from __future__ import annotations

import fcntl
import os
from typing import IO

from ..home import home
from .settings import DEFAULT_VISIBILITY_TIMEOUT, QUEUES, broker_url, celery_settings

DEFINITIONS_MODULE = "assets.definitions"  # imported by every worker at start (Celery's `include`)


def worker_app(broker: str | None = None, visibility_timeout: float = DEFAULT_VISIBILITY_TIMEOUT):
    """The Celery app of a worker: dagster-celery's app and step task on the farm's settings."""
    from dagster_celery.executor import CeleryExecutor
    from dagster_celery.make_app import make_app
    from dagster_celery.tasks import create_task

    broker = broker or broker_url()
    app = make_app(CeleryExecutor.for_cli(broker=broker, backend=broker, include=[DEFINITIONS_MODULE],
                                          config_source=celery_settings(visibility_timeout)).app_args())
    create_task(app)
    return app


# ---- one delivery of a step at a time

_held: dict[str, IO] = {}


def _step_lock_path(task_id: str):
    return home() / "locks" / "steps" / f"{task_id}.lock"


def hold_step(task_id: str | None = None, **_) -> None:
    """Before a step runs: lock its task id on the shared home.

    A message is delivered again when its step outlives the visibility timeout
    (settings.celery_settings). The second delivery waits here until the
    first ends, then runs a stage whose output is already stored: it is found
    cached, and nothing is computed or written twice. A killed holder's lock
    is released by the kernel, so a redelivery after a crash does not wait.
    """
    if task_id is None:
        return
    path = _step_lock_path(task_id)
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        f = open(path, "a")  # noqa: SIM115  (held until the step ends, closed by release_step)
        fcntl.flock(f, fcntl.LOCK_EX)
        try:  # the holder we waited for removes the file: a lock on the removed file excludes nobody
            if os.stat(path).st_ino == os.fstat(f.fileno()).st_ino:
                break
        except FileNotFoundError:
            pass
        f.close()
    _held[task_id] = f


def release_step(task_id: str | None = None, **_) -> None:
    """After a step: remove its lock file (no file is left per step) and release the lock."""
    f = _held.pop(task_id, None) if task_id else None
    if f is not None:
        _step_lock_path(task_id).unlink(missing_ok=True)
        f.close()


def answering(broker: str | None = None, timeout: float = 2.0) -> list[str]:
    """The first worker to answer a ping on the broker, or none within `timeout` seconds (a worker
    with concurrency 1 cannot answer while it runs a step)."""
    replies = worker_app(broker).control.ping(timeout=timeout, limit=1)
    return sorted(name for reply in replies for name in reply)


def _limit_threads(threads: int) -> None:
    from ops.blending.rife_onnx import limit_threads

    limit_threads(threads)


def start_worker(queues: tuple[str, ...] = ("cpu",), concurrency: int = 1, threads: int | None = None,
                 broker: str | None = None, visibility_timeout: float = DEFAULT_VISIBILITY_TIMEOUT,
                 name: str | None = None, loglevel: str = "INFO") -> None:
    """Run a worker until it is stopped. threads: the network's threads per step (default: cores / concurrency)."""
    from celery import signals

    unknown = set(queues) - set(QUEUES)
    if unknown or not queues:
        raise ValueError(f"queues must be among {QUEUES}, got {sorted(queues)}")
    if concurrency < 1:
        raise ValueError(f"concurrency must be >= 1, got {concurrency}")
    threads = threads or max(1, (os.cpu_count() or 1) // concurrency)
    app = worker_app(broker, visibility_timeout)
    signals.task_prerun.connect(hold_step, weak=False)
    signals.task_postrun.connect(release_step, weak=False)
    signals.worker_process_init.connect(lambda **_: _limit_threads(threads), weak=False)  # prefork children
    _limit_threads(threads)  # the solo pool runs steps in this process
    app.worker_main(["worker", "--queues", ",".join(queues), "--concurrency", str(concurrency),
                     "--pool", "solo" if concurrency == 1 else "prefork", "--prefetch-multiplier", "1",
                     "--hostname", name or f"{'-'.join(queues)}-{os.getpid()}@%h", "--loglevel", loglevel,
                     "--without-gossip", "--without-mingle"])
