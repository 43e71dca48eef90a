"""`inbetween watch`: rerun a shot each time its files are saved, as the editor does on Save.

An annotation fixed outside the editor (shot.json in a text editor, a mask repainted, a pipeline tool writing
T-junctions) gets its frames back as fast as a save in the editor: the reruns are the editor's
(`reruns.Reruns`), so while nothing runs the next one waits ready as a standby (assets/standby.py) and a
save hands it the shot as saved; a save during a rerun supersedes it. Only what the save changed recomputes.

A save is seen by polling the shot directory's files (their paths, sizes and modification times) every
POLL_S; once they have stayed the same for SETTLE_S (an editor may write a file in several steps, a tool
several files) the rerun starts. The output folder, the home and hidden files are not watched, so a run's
own writes never start another.
"""
from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

from ..codeversion import ROOT
from ..home import home
from .planning import register
from .reruns import STANDBY_SWITCH, Reruns

POLL_S = 0.25
SETTLE_S = 0.3


def files_state(shot_dir: Path, skip: tuple[Path, ...] = ()) -> tuple:
    """(path, size, mtime_ns) of every file under shot_dir but hidden ones and those under `skip`, sorted."""
    out = []
    for dirpath, dirnames, filenames in os.walk(shot_dir):
        here = Path(dirpath)
        dirnames[:] = sorted(d for d in dirnames if not d.startswith(".") and (here / d).resolve() not in skip)
        for name in sorted(filenames):
            if name.startswith("."):
                continue
            try:
                st = (here / name).stat()
            except OSError:  # removed between the listing and the stat: the next poll sees it gone
                continue
            out.append((str(here / name), st.st_size, st.st_mtime_ns))
    return tuple(out)


def _rerun_commands(run_args: list[str]) -> tuple[list[str], list[str] | None]:
    """The run command and its standby (none with INBETWEEN_STANDBY=0): `run_args` after `inbetween run`."""
    command = [sys.executable, "-m", "assets.cli", "run", *run_args]
    standby = ([sys.executable, "-m", "assets.standby", "run", *run_args]
               if os.environ.get(STANDBY_SWITCH, "1") != "0" else None)
    return command, standby


def watch(shot_dir: str | Path, out_dir: str | Path, run_options: list[str], say: Callable[[str], None],
          stop_after: int | None = None) -> int:
    """Run the shot now, then again after every save, until Ctrl-C (or `stop_after` reruns, for tests); prints a
    line per rerun through `say`. run_options: the flags `inbetween run` takes besides SHOT and --out. The exit
    status: 0."""
    shot = Path(shot_dir).resolve()
    out = Path(out_dir).resolve()
    partition = register(shot)  # a shot that cannot be read fails here, before anything runs
    workdir = home() / "watch" / partition
    command, standby = _rerun_commands([str(shot), "--out", str(out), *run_options])
    reruns = Reruns(shot, partition, workdir, home(), ROOT, command, standby, out_dir=out)
    skip = (out, home(), workdir)
    say(f"watching {shot_dir} (Ctrl-C to stop): each save reruns what it changed; frames -> {out / 'frames'}")
    reruns.start()
    seen, done = files_state(shot, skip), 0
    signal.signal(signal.SIGTERM, _interrupt)  # a script's kill ends it as Ctrl-C does: its reruns with it
    try:
        seq = reruns.request("start")
        while stop_after is None or done < stop_after:
            seq, finished = _follow(reruns, seq, say)
            done += finished
            state = files_state(shot, skip)
            if state != seen:
                time.sleep(SETTLE_S)
                settled = files_state(shot, skip)
                if settled != state:  # still being written
                    continue
                seen = settled
                seq = reruns.request("saved")
            else:
                time.sleep(POLL_S)
    except KeyboardInterrupt:
        say("stopped")
    finally:
        reruns.stop(cancel=True)
    return 0


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _follow(reruns: Reruns, seq: int, say: Callable[[str], None]) -> tuple[int, int]:
    """Report rerun `seq` once it ended: (seq, 1), then (-1, 0) on later calls; (seq, 0) while it runs."""
    if seq < 0:
        return seq, 0
    _, status = reruns.snapshot()
    if status["seq"] != seq or status["state"] == "running":
        return seq, 0
    took = (status["finished"] or time.time()) - (status["started"] or time.time())
    reason = status.get("reason") or "run"
    if status["state"] == "done":
        ran = sum(1 for s in status["stages"].values() if not s["cached"])
        cached = len(status["stages"]) - ran
        say(f"{reason}: done in {took:.1f} s ({ran} ran, {cached} cached)")
    else:
        say(f"{reason}: failed after {took:.1f} s: {status['error']}")
    return -1, 1
