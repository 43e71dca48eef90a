"""Per-stage progress of a run, for whichever front end started it (CLI bar, editor stream).

A stage emits "start" and "done" events (with cached, seconds, cpu_seconds, warnings).
In the process that runs the stages, listeners registered with `listen`
receive them; when INBETWEEN_PROGRESS names a file, they are also appended to
it as JSON lines, so a front end can follow steps that run in other processes
(a multiprocess or Celery executor) by reading that file.
"""
from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

Listener = Callable[[dict], None]
_listeners: list[Listener] = []
ENV_FILE = "INBETWEEN_PROGRESS"


def emit(partition: str, stage: str, event: str, **fields) -> None:
    """Report one stage event to the listeners and the progress file, if any."""
    record = {"time": time.time(), "partition": partition, "stage": stage, "event": event, **fields}
    for fn in list(_listeners):
        fn(record)
    path = os.environ.get(ENV_FILE)
    if path:
        with open(path, "a") as f:  # one short line per write: appends from several processes do not interleave
            f.write(json.dumps(record) + "\n")


@contextmanager
def listen(fn: Listener) -> Iterator[None]:
    """Call fn(event) for every stage event emitted in this process while the context is open."""
    _listeners.append(fn)
    try:
        yield
    finally:
        _listeners.remove(fn)
