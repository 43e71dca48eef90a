"""What the farm's processes must agree on: the broker, the queues, the Celery settings. No Celery import.

The orchestrating process (the CLI's batch, or a run launched from the UI)
and every worker build their Celery app from `celery_settings`, so queue
names and delivery rules cannot drift apart between them.
"""
from __future__ import annotations

import os

BROKER_ENV = "INBETWEEN_BROKER"  # redis://HOST:6379/0; the results go to the same Redis
DEFAULT_BROKER = "redis://127.0.0.1:6379/0"
CPU_QUEUE, GPU_QUEUE = "cpu", "gpu"
QUEUES = (CPU_QUEUE, GPU_QUEUE)
GPU_RESOURCE = "rife"  # stages that declare this resource run the network: rife_matrix, evaluation/rife_direct

# Two hours: longer than any one stage of a full-size shot on a CPU. A step whose worker holds it unacknowledged
# for longer is handed to another worker (see `celery_settings`).
DEFAULT_VISIBILITY_TIMEOUT = 7200.0


def missing_extra() -> str | None:
    """Why the farm cannot run here (its packages are not installed), or None."""
    from importlib.util import find_spec

    missing = [m for m in ("dagster_celery", "dagster_postgres", "redis") if find_spec(m) is None]
    if missing:
        return f"the farm needs {', '.join(missing)}: pip install -e '.[farm]' (docs/production.md)"
    return None


def broker_url() -> str:
    return os.environ.get(BROKER_ENV, DEFAULT_BROKER)


def queue_for(resource_keys: set[str] | frozenset[str], device: str | None = None) -> str:
    """The queue of a step: `gpu` for a stage that runs RIFE when INBETWEEN_DEVICE=cuda, else `cpu`."""
    device = device if device is not None else os.environ.get("INBETWEEN_DEVICE", "cpu")
    return GPU_QUEUE if device == "cuda" and GPU_RESOURCE in resource_keys else CPU_QUEUE


def celery_settings(visibility_timeout: float = DEFAULT_VISIBILITY_TIMEOUT) -> dict:
    """Celery's lowercase settings for the farm's app, in the orchestrator and in every worker.

    A step's message is acknowledged only when the step has ended (acks_late). A
    worker killed in the middle of a step never acknowledges it, so Redis keeps
    it among the unacknowledged messages and, `visibility_timeout` seconds
    after it was delivered, puts it back on its queue for another worker. The
    stage then runs again from its inputs: its output is written as a whole or
    not at all (resources/store.py), so the rerun finds nothing half-written.
    The timeout must exceed the longest stage: a step still running after it
    is delivered a second time (worker.py makes the copy wait, then find the
    stage cached).
    """
    return {
        "task_acks_late": True,
        "task_reject_on_worker_lost": True,  # a pool child killed mid-step: requeue rather than acknowledge
        "worker_prefetch_multiplier": 1,  # a worker reserves no step beyond the ones it runs
        "task_default_queue": CPU_QUEUE,
        "task_track_started": True,  # the result backend says which worker holds a step
        "result_expires": 7 * 24 * 3600,
        "broker_connection_retry_on_startup": True,
        "broker_transport_options": {
            "visibility_timeout": float(visibility_timeout),
            # sweep for abandoned messages every few seconds instead of every 100 s (kombu's default 10 x 10)
            "unacked_restore_interval": max(1, min(10, int(visibility_timeout // 4))),
            "unacked_restore_throttle": 1,
            "max_retries": 3, "interval_start": 0, "interval_step": 0.2, "interval_max": 0.5,  # dagster-celery's
        },
    }
