"""The CLI's progress lines and batch table (assets/console.py), on fake streams and a real progress file."""
from __future__ import annotations

import io
import json
import multiprocessing as mp
import os
import re

from assets import progress
from assets.console import Board, ShotLine, table

STAGES = ("a/masks", "a/template", "rife_matrix", "frames")


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_line_shows_ran_cached_running_and_warnings():
    line = ShotLine("shot", STAGES)
    line.feed({"stage": "a/masks", "event": "start", "time": 0.0})
    line.feed({"stage": "a/masks", "event": "done", "cached": True, "seconds": 0.1, "warnings": 0})
    line.feed({"stage": "a/template", "event": "start", "time": 0.0})
    line.feed({"stage": "a/template", "event": "done", "cached": False, "seconds": 2.5, "warnings": 2})
    line.feed({"stage": "rife_matrix", "event": "start", "time": 10.0})
    line.feed({"stage": "not a stage", "event": "done"})  # ignored
    text = line.render(now=22.0)
    assert re.match(r"^shot\s+\[=#>\.\]  2/4  rife_matrix running 12 s   warnings: a/template 2$", text), text
    # the shot's wall time from its report, not the sum of its stages' seconds (the lanes overlap)
    line.finish({n: {"cached": n != "rife_matrix", "seconds": 1.0} for n in STAGES}, {"a/template": 2}, seconds=3.2)
    assert line.bar() == "==#=" and "ok: 1 ran, 3 cached, 3.2 s" in line.render()


def test_board_redraws_in_place_on_a_terminal_and_prints_once_elsewhere():
    tty, log = Tty(), io.StringIO()
    for stream in (tty, log):
        board = Board(STAGES, stream=stream)
        for name in ("one", "two"):
            board.line(name, name)
        board.feed({"partition": "one", "stage": "a/masks", "event": "done", "cached": False, "seconds": 1})
        board.feed({"partition": "one", "stage": "a/template", "event": "start", "time": 0.0})
        board.draw()
        board.draw()
        board.finish("one", "one", None, "failed")
        board.say("waiting: another run holds the lock")
    assert "\x1b[2F" in tty.getvalue()  # moved up over its two lines before redrawing them
    assert log.getvalue().splitlines() == [
        "one              [#x..]  1/4  failed in a/template",
        "waiting: another run holds the lock",
    ]


def _emit_from_another_process(path: str) -> None:
    os.environ[progress.ENV_FILE] = path
    progress.emit("p", "a/masks", "start")
    progress.emit("p", "a/masks", "done", cached=False, seconds=0.5, warnings=1)


def test_follow_reads_events_of_other_processes(tmp_path, monkeypatch):
    monkeypatch.setenv("INBETWEEN_HOME", str(tmp_path / "home"))
    monkeypatch.delenv(progress.ENV_FILE, raising=False)
    board = Board(STAGES, stream=io.StringIO())
    with board.follow():
        path = os.environ[progress.ENV_FILE]
        proc = mp.get_context("spawn").Process(target=_emit_from_another_process, args=(path,))
        proc.start()
        proc.join()
        progress.emit("q", "frames", "done", cached=True, seconds=0.0, warnings=0)  # and of this one
    assert board.lines["p"].done == {"a/masks": {"cached": False, "seconds": 0.5, "warnings": 1}}
    assert board.lines["q"].bar() == "...="
    assert progress.ENV_FILE not in os.environ and not os.path.exists(path)  # its own file: removed


def test_follow_keeps_a_progress_file_the_user_named(tmp_path, monkeypatch):
    path = tmp_path / "mine.jsonl"
    path.write_text(json.dumps({"partition": "old", "stage": "frames", "event": "done"}) + "\n")
    monkeypatch.setenv(progress.ENV_FILE, str(path))
    board = Board(STAGES, stream=io.StringIO())
    with board.follow():
        progress.emit("new", "frames", "start")
    assert set(board.lines) == {"new"}  # read from where the file ended
    assert path.exists() and os.environ[progress.ENV_FILE] == str(path)


def test_table_columns():
    text = table([{"shot": "arm_cross", "frames": 9, "seconds": 41.234, "cached": "3/14", "warnings": 2, "status": "ok"},
                  {"shot": "bad", "seconds": "-", "status": "bad input"}])
    lines = text.splitlines()
    assert lines[0].split() == ["shot", "frames", "seconds", "cached", "warnings", "status"]
    assert lines[2].split() == ["arm_cross", "9", "41.2", "3/14", "2", "ok"]
    assert lines[3].split() == ["bad", "-", "-", "-", "-", "bad", "input"]
