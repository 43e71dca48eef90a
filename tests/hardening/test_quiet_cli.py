"""The CLI is quiet (issue 10): stderr holds one progress line per shot and error lines, nothing else.

No Dagster DEBUG line, no BetaWarning/PreviewWarning, no traceback, for run, batch, status, masks and
eval; --verbose shows Dagster's event log live; a failing stage is one line with the log's path, in
run and in batch (whose table says which shot failed).
"""
from __future__ import annotations

import os
import re

import pytest

from assets.graph import shot_graph

from .conftest import ROOT, SHOT, cli, env_for

pytestmark = pytest.mark.slow

NOISE = ("Traceback", "DEBUG", "Warning", "warnings.warn", "dagster - ")


def progress_line(line: str) -> bool:
    """A shot's progress line: its name, the bar over a two-key shot's stages, the count."""
    n = len(shot_graph(2).stages)
    return re.match(rf"^{SHOT}\s+\[[#=>.x]{{{n}}}\]\s+\d+/{n}  ", line) is not None


def assert_quiet(done, allowed=progress_line) -> None:
    for word in NOISE:
        assert word not in done.stderr, done.stderr
    for line in done.stderr.splitlines():
        assert allowed(line), f"unexpected stderr line: {line!r}"


def test_every_command_is_quiet(warm, tmp_path):
    root = str(warm.shot.parent)
    done = cli(warm.home, "run", str(warm.shot), "--out", str(tmp_path / "out"))  # fresh: Dagster not started
    assert done.returncode == 0 and done.stdout.startswith("3 frames -> ")
    assert_quiet(done)
    n = len(shot_graph(2).stages)
    assert len(done.stderr.splitlines()) == 1 and f"{n} cached" in done.stderr

    warm.forget_dagster_record()  # Dagster runs now (it re-records every stage, all cached)
    done = cli(warm.home, "run", str(warm.shot), "--out", str(tmp_path / "out"))
    assert done.returncode == 0
    assert_quiet(done)
    logs = sorted((warm.home / "logs").glob("*.log"))
    assert logs and "STEP_START" in logs[-1].read_text()  # the event log went to the file instead

    for args in (["status", str(warm.shot)], ["status", str(warm.shot), "--json"],
                 ["masks", str(warm.shot), "--out", str(tmp_path / "masks")]):
        done = cli(warm.home, *args)
        assert done.returncode == 0 and done.stdout
        assert_quiet(done, allowed=lambda line: False)

    done = cli(warm.home, "batch", root, "--out", str(tmp_path / "batch"))
    assert done.returncode == 0
    assert_quiet(done)
    rows = [line.split() for line in done.stdout.splitlines()]
    assert rows[0] == ["shot", "frames", "seconds", "cached", "warnings", "status"]
    assert rows[2][0] == SHOT and rows[2][1] == "3" and rows[2][3] == f"{n}/{n}" and rows[2][5] == "ok"

    done = cli(warm.home, "eval", root, "--out", str(tmp_path / "eval"))
    assert done.returncode == 0 and "written:" in done.stdout
    assert_quiet(done, allowed=lambda line: False)


def test_verbose_shows_the_event_log_live(warm, tmp_path):
    warm.forget_dagster_record()
    done = cli(warm.home, "run", str(warm.shot), "--out", str(tmp_path / "out"), "--verbose")
    assert done.returncode == 0
    assert "STEP_START" in done.stderr or "STEP_SUCCESS" in done.stderr


def _break_a_stored_stage(warm) -> None:
    """Same-size garbage in key0's deformed frames (intact by size, unreadable), and their reader missing."""
    npz = warm.home / "storage" / warm.partition / "seg0" / "key0" / "deformed_frames" / "arrays.npz"
    npz.write_bytes(os.urandom(npz.stat().st_size))
    import shutil

    shutil.rmtree(warm.home / "storage" / warm.partition / "seg0" / "rife_matrix")


def test_a_failing_stage_is_one_line_with_the_log(warm, tmp_path):
    _break_a_stored_stage(warm)
    done = cli(warm.home, "run", str(warm.shot), "--out", str(tmp_path / "out"))
    assert done.returncode == 1
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, done.stderr
    assert "Traceback" not in done.stderr
    line = errors[0]
    assert f"{warm.shot}: seg0/rife_matrix: " in line and "; fix: " in line
    log = re.search(r"\(full log: (\S+)\)$", line).group(1)
    assert "Traceback" in open(log).read() or "Error" in open(log).read()
    assert not (tmp_path / "out" / "frames").exists()

    done = cli(warm.home, "batch", str(warm.shot.parent), "--out", str(tmp_path / "batch"))
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert [line.split()[-1] for line in done.stdout.splitlines()[2:3]] == ["failed"]
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "seg0/rife_matrix" in errors[0], done.stderr


def test_the_process_leaves_past_a_stage_still_computing_ahead():
    """A failed run returns while a work-ahead thread may still be inside native code; the command leaves
    without finalizing the interpreter under it (which aborted with SIGABRT now and then): the exit code is
    the run's, what was said is flushed, and the thread is not waited for."""
    import subprocess
    import sys
    import time

    code = (
        "import sys, threading, time\n"
        "from assets.run.leave import leave\n"
        "threading.Thread(target=time.sleep, args=(30,), name='inbetween-ahead-0', daemon=True).start()\n"
        "print('error: said before leaving', end='')\n"
        "leave(3, wait_s=0.1)\n"
        "sys.exit(0)\n"
    )
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=20)
    assert done.returncode == 3 and done.stdout == "error: said before leaving"
    assert time.monotonic() - t0 < 15


def test_a_finished_command_leaves_without_tearing_the_interpreter_down():
    """Done and nothing computing: the exit code is the command's, the atexit handlers ran (a run's log is
    flushed by logging's), and what was printed to a pipe arrives; nothing after leave() runs."""
    import subprocess
    import sys

    code = (
        "import atexit, logging, sys\n"
        "from assets.run.leave import leave\n"
        "atexit.register(lambda: print('atexit ran', end=''))\n"
        "handler = logging.FileHandler(sys.argv[1])\n"
        "logging.getLogger('x').addHandler(handler)\n"
        "logging.getLogger('x').warning('logged')\n"
        "print('said; ', end='')\n"
        "leave(4)\n"
        "print('went on')\n"
    )
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        log = Path(d) / "run.log"
        done = subprocess.run([sys.executable, "-c", code, str(log)], capture_output=True, text=True, timeout=20)
        assert done.returncode == 4 and done.stdout == "said; atexit ran", done
        assert log.read_text().strip() == "logged"


def test_one_time_figure_on_stderr_stdout_report_and_the_wall_clock(warm, tmp_path):
    """The shot's line on stderr, the result line on stdout and report.json give one time, the command's own:
    within the wall clock of the process (which adds only the interpreter's start and its exit)."""
    import json
    import re
    import subprocess
    import sys
    import time

    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "assets.cli", "run", str(warm.shot), "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, env=env_for(warm.home), cwd=ROOT, timeout=600)
    wall = time.perf_counter() - t0
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    total = report["seconds_total"]
    assert f"{total:.1f} s)" in done.stdout and f"cached, {total:.1f} s" in done.stderr
    assert total <= wall and wall - total < 2.0, (total, wall)
    assert not re.search(r"\d+\.\d s", done.stderr.replace(f"{total:.1f} s", ""))  # no second figure


def test_eval_scores_the_other_shots_when_one_fails(warm, tmp_path):
    """A shot whose input is bad is one error line and one row of the summary's failed shots; the others are
    scored, and eval exits 2 as batch does for bad input."""
    import json
    import shutil

    root = tmp_path / "two_shots"
    good, bad = root / SHOT, root / "broken"
    shutil.copytree(warm.shot, good)
    shutil.copytree(warm.shot, bad)
    data = json.loads((bad / "shot.json").read_text())
    data["keyframes"][1] = "missing.png"
    (bad / "shot.json").write_text(json.dumps(data))
    done = cli(warm.home, "eval", str(root), "--out", str(tmp_path / "eval"))
    assert done.returncode == 2, done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "missing.png" in errors[0]
    assert_quiet(done, allowed=lambda line: line.startswith("error:") or "shots failed: broken" in line
                 or progress_line(line))
    summary = (tmp_path / "eval" / "summary.md").read_text()
    means, failed = summary.split("## Failed shots")
    assert f"| {SHOT} | ours |" in means and "broken" not in means
    assert "| broken | " in failed and "missing.png" in failed
