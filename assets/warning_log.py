"""Python warnings to a file instead of the terminal, in this process and in the worker processes it starts.

No Dagster import: the lanes' worker processes (assets/processes.py) route their warnings with it too.
"""
from __future__ import annotations

import os
import time
import warnings
from pathlib import Path

_routed: Path | None = None  # where this process's warnings go (None: the terminal)


def route_warnings(path: str | Path) -> Path:
    """Send every Python warning of this process to `path` (appended, one line each, with the time and the pid)."""
    global _routed
    path = Path(path)

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            with open(path, "a") as f:
                f.write(f"{time.strftime('%Y-%m-%d %H:%M:%S')} {os.getpid()} "
                        f"{warnings.formatwarning(message, category, filename, lineno, line).rstrip()}\n")
        except OSError:
            pass  # a warning never fails a run

    warnings.showwarning = show
    _routed = path
    return path


def routed() -> Path | None:
    """The file this process's warnings go to, if route_warnings sent them to one."""
    return _routed
