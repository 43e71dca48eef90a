"""Leaving a finished command without finalizing the interpreter: the one place of the project's exit tricks.

Tearing down every module and object a run loaded (torch, Dagster, SQLAlchemy) takes 0.5 s of every command
and does nothing for us once the outputs are written and closed. So a finished command (and a batch worker
whose result is sent) runs the atexit handlers (logging flushes its files), flushes the standard streams and
calls os._exit. The atexit handlers are skipped when a stage still computes on a work-ahead thread after
another failed: that thread may be inside native code (torch, Triangle, OpenCV), and finalizing under it
aborted the process now and then ("terminate called without an active exception": SIGABRT, not exit 1).
"""
from __future__ import annotations

import os
import sys
import threading
import time


def exit_without_teardown(code: int, run_atexit: bool = True) -> None:
    """Exit with `code` now, skipping the interpreter's finalization; the atexit handlers run first unless
    `run_atexit` is False (the logs are flushed either way), then the standard streams are flushed."""
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


def leave(code: int, wait_s: float = 0.5) -> None:
    """Exit a finished command with `code`: the atexit handlers run unless a stage still computes on a
    work-ahead thread (assets/ahead.py names them inbetween-ahead-*) after `wait_s` seconds."""
    workers = [t for t in threading.enumerate() if t.name.startswith("inbetween-ahead")]
    deadline = time.monotonic() + wait_s
    for t in workers:
        t.join(max(0.0, deadline - time.monotonic()))
    exit_without_teardown(code, run_atexit=not any(t.is_alive() for t in workers))
