"""CPU seconds spent for the calling thread elsewhere: in worker processes, on a pool's threads.

A stage's cost (report.json's `cpu_seconds`) is its own thread's CPU plus the CPU of the work it handed off and
waited for. Whoever hands work off charges what that work took to the thread that waited for it; the stage reads
the difference of `charged()` over its run (assets/compute.py run_stage).
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

_charged = threading.local()  # per thread: CPU seconds spent for it elsewhere so far


def charge(seconds: float) -> None:
    """Add `seconds` of CPU spent elsewhere (another thread, another process) to this thread's account."""
    _charged.seconds = charged() + float(seconds)


def charged() -> float:
    """CPU seconds charged to this thread so far."""
    return getattr(_charged, "seconds", 0.0)


def thread_cpu(fn: Callable[..., Any]) -> Callable[..., float]:
    """fn, returning instead the CPU seconds of the thread that ran it (for a pool's task: the caller charges
    them; fn's own result is not kept)."""
    def timed(*args: Any) -> float:
        start = time.thread_time()
        fn(*args)
        return time.thread_time() - start
    return timed
