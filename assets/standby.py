"""A run made ready before it is asked for: the next rerun of the editor or `inbetween watch`
(assets/run/reruns.py).

    python -m assets.standby run SHOT --out OUT [the run's other options]

does now what every run does before its first stage can start, while nobody waits: it imports Dagster and the
stage definitions, starts the worker processes (their fork server imports the ops), opens the Dagster
instance, loads the network and builds the shot's asset job. Then it prints `ready` and waits for one line on
stdin: a JSON object of environment variables for the run (a progress file). On that line it runs the command
exactly as `inbetween run ...` would, its clock starting then, and exits with the run's code. At the end of
input without a line (the front end closed, or dropped this standby) it exits 0, having written and locked
nothing: of the shot only its number of keys was read (for its asset job), so a shot saved meanwhile is the
one that runs.

The code that runs is the code imported when the standby started: its front end (the editor,
`inbetween watch`) starts a fresh process instead when the project's sources changed since
(`assets.run.reruns.stale`, by codeversion.project_fingerprint, as the plan tells stale code records).
"""
from __future__ import annotations

import json
import os
import sys
from collections.abc import Sequence

READY = "ready"  # printed on stdout once warmed up


def warm_up(argv: Sequence[str] = ()) -> None:
    """Import, start and open everything a run of `argv` (`run SHOT ...`) would before its first stage; failures
    are left to the run."""
    from ops.settings import Settings

    from . import processes
    from .run import warnings_to_log

    warnings_to_log()
    processes.pool()  # the fork server imports the ops meanwhile
    from . import ahead, cli  # noqa: F401  (the stages and the work-ahead; what the go line runs)
    from .resource_types import model_resources
    from .run.session import Session

    session = Session.get(Settings())
    session.instance  # noqa: B018  (opens it: SQLite's tables, Alembic's check)
    model_resources()["rife"].load()  # cached per process, as the run's stage will ask for it
    processes.wait_started()
    if len(argv) > 1 and argv[0] == "run":  # the shot's asset job, for the number of keys it has now
        try:
            from ops.shotio.load import load_shot

            from .graph import shot_graph

            session.job(shot_graph(load_shot(argv[1]).n_keys))
        except Exception:  # noqa: BLE001  (a shot bad now may be saved good before the line: the run tells)
            pass


def main(argv: list[str]) -> int:
    """Warm up, wait for the go line, run the `inbetween` command `argv`; the exit status."""
    try:
        warm_up(argv)
    except Exception:  # noqa: BLE001  (the run does the same again and reports it in its one line)
        pass
    print(READY, flush=True)
    line = sys.stdin.readline()
    if not line.strip():
        return 0
    try:
        env = json.loads(line)
        os.environ.update({str(k): str(v) for k, v in env.items()})
    except (ValueError, AttributeError):
        print(f"error: standby: the line on stdin is not a JSON object of environment variables: {line[:80]!r}",
              file=sys.stderr)
        return 2
    from .cli import main as cli_main

    return cli_main(argv)


if __name__ == "__main__":
    code = main(sys.argv[1:])
    from .run.leave import leave

    leave(code)
