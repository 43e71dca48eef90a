"""What the CLI shows while shots run: one line per shot with a bar over its stages, and the batch table.

The lines are fed by assets/progress.py's stage events (start; done with cached, seconds, warnings),
read from the INBETWEEN_PROGRESS file, so stages that run in other processes (batch workers, a
multiprocess executor) show as well as in-process ones. On a terminal the lines are redrawn in place;
elsewhere (a log file, CI) a shot's line is printed once, when the shot ends. A line reads

    arm_cross      [######====>...]  10/14  rife_matrix running 12 s   warnings: key1/masks 2

'#' a stage that ran, '=' one that was cached, '>' the one running, '.' one still to come,
'x' the one that failed.
"""
from __future__ import annotations

import json
import os
import shutil
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from . import progress

NAME_WIDTH = 16
POLL_SECONDS = 0.2


@dataclass
class ShotLine:
    """Progress of one shot over its stages (in graph order)."""

    name: str
    stages: tuple[str, ...]
    done: dict[str, dict] = field(default_factory=dict)  # stage -> {"cached", "seconds", "warnings"}
    running: str | None = None
    since: float = 0.0  # when the running stage started (time.time())
    status: str = "waiting"  # waiting | running | ok | bad input | failed
    wall: float | None = None  # the shot's wall time from its report (seconds_total), once it ended

    def feed(self, event: dict) -> None:
        """Take one progress event of this shot."""
        stage = event.get("stage")
        if stage not in self.stages:
            return
        self.status = "running" if self.status == "waiting" else self.status
        if event.get("event") == "start":
            self.running, self.since = stage, float(event.get("time", time.time()))
        elif event.get("event") == "done":
            self.done[stage] = {"cached": bool(event.get("cached")), "seconds": float(event.get("seconds", 0.0)),
                                "warnings": int(event.get("warnings", 0))}
            if self.running == stage:
                self.running = None

    def finish(self, stages: dict[str, dict], warnings: dict[str, int], status: str = "ok",
               seconds: float | None = None) -> None:
        """Complete the line from a run's report: every stage's cached and seconds, warnings per stage, and the
        shot's wall time (report.json's seconds_total: the one time figure every front end prints)."""
        self.wall = seconds
        for name in self.stages:
            if name in stages:
                self.done[name] = {"cached": bool(stages[name].get("cached")),
                                   "seconds": float(stages[name].get("seconds", 0.0)),
                                   "warnings": int(warnings.get(name, 0))}
        self.running, self.status = None, status

    def bar(self) -> str:
        marks = []
        for name in self.stages:
            d = self.done.get(name)
            if name == self.running:
                marks.append("x" if self.status == "failed" else ">")
            else:
                marks.append("." if d is None else "=" if d["cached"] else "#")
        return "".join(marks)

    def warnings(self) -> dict[str, int]:
        return {n: d["warnings"] for n, d in self.done.items() if d["warnings"]}

    def render(self, now: float | None = None) -> str:
        """The one line of this shot."""
        n = len(self.done)
        if self.running and self.status == "failed":
            detail = f"failed in {self.running}"
        elif self.running:
            detail = f"{self.running} running {(now or time.time()) - self.since:.0f} s"
        elif self.status in ("bad input", "failed") and not self.done:
            detail = self.status
        elif self.status in ("ok", "bad input", "failed"):
            ran = [d for d in self.done.values() if not d["cached"]]
            # the wall time when the run reported it; the two lanes compute at once, so the sum of the stages'
            # seconds is more than the shot took and is not printed as its time
            took = f", {self.wall:.1f} s" if self.wall is not None else ""
            detail = f"{self.status}: {len(ran)} ran, {n - len(ran)} cached{took}"
        elif self.done:
            last = list(self.done)[-1]
            d = self.done[last]
            detail = f"{last} {'cached' if d['cached'] else 'ran'} {d['seconds']:.1f} s"
        else:
            detail = self.status
        w = self.warnings()
        tail = ("   warnings: " + ", ".join(f"{k} {v}" for k, v in w.items())) if w else ""
        return f"{self.name[:NAME_WIDTH]:<{NAME_WIDTH}} [{self.bar()}] {n:>2}/{len(self.stages)}  {detail}{tail}"


def own_stderr() -> TextIO:
    """A stream on a duplicate of file descriptor 2: image decoding captures fd 2 for a moment
    (ops/shotio/image_io.py), and what is drawn here must not land in that capture."""
    try:
        return os.fdopen(os.dup(2), "w", buffering=1, encoding="utf-8", errors="replace")
    except OSError:
        return sys.stderr


class Board:
    """The progress lines of one command: redrawn in place on a terminal, printed once per shot elsewhere."""

    def __init__(self, stages: tuple[str, ...] | Callable[[str], tuple[str, ...]], stream: TextIO | None = None,
                 live: bool | None = None):
        """stages: every shot's stages, or a function partition -> that shot's (shots of any number of keys)."""
        self.stages = stages
        self.stream = stream or own_stderr()
        self.live = self.stream.isatty() if live is None else live
        self.lines: dict[str, ShotLine] = {}  # partition -> line
        self._drawn = 0
        self._printed: set[str] = set()
        self._lock = threading.Lock()

    def line(self, partition: str, name: str | None = None) -> ShotLine:
        """The line of a partition (created on first use, named after the shot)."""
        if partition not in self.lines:
            stages = self.stages(partition) if callable(self.stages) else self.stages
            self.lines[partition] = ShotLine(name or partition, stages)
        return self.lines[partition]

    def feed(self, event: dict) -> None:
        partition = event.get("partition")
        if isinstance(partition, str):
            with self._lock:
                self.line(partition).feed(event)

    def draw(self) -> None:
        """Redraw every line in place (a terminal only)."""
        if not self.live:
            return
        with self._lock:
            now = time.time()
            width = shutil.get_terminal_size((120, 24)).columns - 1  # a wrapped line would break the redraw
            text = [line.render(now)[:width] for line in self.lines.values()]
            up = f"\x1b[{self._drawn}F" if self._drawn else ""
            self.stream.write(up + "".join(f"\x1b[2K{t}\n" for t in text))
            self.stream.flush()
            self._drawn = len(text)

    def finish(self, partition: str, name: str, report: dict | None, status: str) -> ShotLine:
        """Complete a shot's line from its run report (None when it failed) and show it as ended."""
        with self._lock:
            line = self.line(partition, name)
            if report is not None:
                stages = report["stages"]
                line.finish(stages, {n: s.get("warnings", 0) for n, s in stages.items()}, status,
                            report.get("seconds_total"))
            else:  # the stage that was running is where it failed
                line.status = status
        self.ended(partition)
        return line

    def ended(self, partition: str) -> None:
        """A shot ended: elsewhere than on a terminal its final line is printed now, once."""
        if self.live:
            self.draw()
        elif partition not in self._printed and partition in self.lines:
            self._printed.add(partition)
            self.stream.write(self.lines[partition].render() + "\n")
            self.stream.flush()

    def say(self, text: str) -> None:
        """A message line above the progress lines (e.g. that a run waits for another one's lock)."""
        with self._lock:
            if self.live and self._drawn:
                self.stream.write(f"\x1b[{self._drawn}F\x1b[J")
                self._drawn = 0
            self.stream.write(text + "\n")
            self.stream.flush()
        self.draw()

    @contextmanager
    def follow(self) -> Iterator[None]:
        """Feed the board with the stage events of everything run inside the block, in any process.

        The events come through the INBETWEEN_PROGRESS file: the one the user set (read from its current
        end), or a private one under INBETWEEN_HOME/logs that is removed afterwards.
        """
        from .home import home

        own = progress.ENV_FILE not in os.environ
        if own:
            path = home() / "logs" / f"progress-{os.getpid()}-{threading.get_ident()}.jsonl"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text("")
            os.environ[progress.ENV_FILE] = str(path)
        path = Path(os.environ[progress.ENV_FILE])
        offset = path.stat().st_size if path.exists() else 0
        stop = threading.Event()
        state = {"offset": offset, "rest": ""}

        def poll() -> None:
            try:
                with open(path, encoding="utf-8", errors="replace") as f:
                    f.seek(state["offset"])
                    chunk = f.read()
                    state["offset"] = f.tell()
            except OSError:
                return
            lines = (state["rest"] + chunk).split("\n")
            state["rest"] = lines.pop()  # a line still being written
            for text in lines:
                try:
                    self.feed(json.loads(text))
                except (ValueError, TypeError, AttributeError):
                    continue

        def loop() -> None:
            while not stop.wait(POLL_SECONDS):
                poll()
                self.draw()

        thread = threading.Thread(target=loop, name="inbetween-progress", daemon=True)
        thread.start()
        try:
            yield
        finally:
            stop.set()
            thread.join()
            poll()
            if own:
                os.environ.pop(progress.ENV_FILE, None)
                path.unlink(missing_ok=True)


def table(rows: list[dict]) -> str:
    """The batch summary: shot, frames, seconds, cached stages, warnings, status; one row per shot."""
    head = ["shot", "frames", "seconds", "cached", "warnings", "status"]
    body = [[str(r["shot"]), str(r.get("frames", "-")), r["seconds"] if isinstance(r.get("seconds"), str)
             else f"{r.get('seconds', 0.0):.1f}", str(r.get("cached", "-")), str(r.get("warnings", "-")),
             str(r["status"])] for r in rows]
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)]
    right = {1, 2, 4}

    def fmt(cells):
        return "  ".join(c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(cells, widths))).rstrip()

    return "\n".join([fmt(head), fmt(["-" * w for w in widths]), *(fmt(b) for b in body)])
