"""Where a run's logs and Python warnings go: files under INBETWEEN_HOME/logs, not the terminal."""
from __future__ import annotations

import os
import time
import warnings
from pathlib import Path

from ..home import home
from ..warning_log import route_warnings


def quiet_dagster_warnings() -> None:
    import dagster as dg

    for category in (dg.BetaWarning, dg.PreviewWarning, getattr(dg, "ExperimentalWarning", None)):
        if category is not None:
            warnings.filterwarnings("ignore", category=category)


def warnings_to_log() -> Path:
    """Send every Python warning of this process, and of the worker processes its runs start, to
    INBETWEEN_HOME/logs/warnings.log instead of stderr.

    Dagster's Beta/Preview warnings, a library's DeprecationWarning, numpy's RuntimeWarning on odd input:
    none is the user's business on the terminal (--verbose leaves them there).
    """
    return route_warnings(home() / "logs" / "warnings.log")


def log_path(partition: str) -> Path:
    """A new log file for one run of a partition."""
    return home() / "logs" / f"{time.strftime('%Y%m%d-%H%M%S')}-{partition}-{os.getpid()}.log"
