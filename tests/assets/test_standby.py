"""The standby run (assets/standby.py): ready before it is asked for, the shot read only once it is, the same
run as `inbetween run`."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from assets.cli import main
from assets.codeversion import project_fingerprint
from assets.run.reruns import stale

from .conftest import frames_of

ROOT = Path(__file__).resolve().parents[2]


def standby(shot: Path, out: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "assets.standby", "run", str(shot), "--out", str(out)], cwd=ROOT,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})


def wait_ready(proc: subprocess.Popen) -> None:
    """Read the standby's output up to its `ready` line (a first run on a machine may print the network's export
    before it)."""
    for _ in range(200):
        line = proc.stdout.readline()
        if line.strip() == "ready":
            return
        assert line, "the standby ended before it said ready"
    raise AssertionError("no ready line")


def test_stale_when_a_source_changed_since_the_standby(tmp_path):
    source = tmp_path / "assets" / "run" / "x.py"
    source.parent.mkdir(parents=True)
    source.write_text("")
    then = project_fingerprint(tmp_path)
    (tmp_path / "data.json").write_text("{}")  # not code: never makes it stale
    os.utime(source, (time.time() + 10, time.time() + 10))  # touched, not changed
    assert not stale(tmp_path, then)
    source.write_text("x = 1\n")
    assert stale(tmp_path, then)


@pytest.mark.slow  # a real run in a process of its own, and a second one that finds everything cached
def test_a_standby_runs_the_shot_as_saved_after_it_got_ready(home, small_shot, tmp_path):
    proc = standby(small_shot, tmp_path / "out")
    wait_ready(proc)
    assert not (tmp_path / "out").exists() and not (home / "storage").exists()  # nothing of the shot read yet
    # saved while the standby waits: the run takes this version
    data = json.loads((small_shot / "shot.json").read_text())
    x, y = data["t_junctions"][1][0]
    data["t_junctions"][1][0] = [x + 1.0, y]
    (small_shot / "shot.json").write_text(json.dumps(data))
    progress = tmp_path / "progress.jsonl"
    output, _ = proc.communicate(json.dumps({"INBETWEEN_PROGRESS": str(progress)}) + "\n", timeout=600)
    assert proc.returncode == 0, output
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    done = {json.loads(line)["stage"] for line in progress.read_text().splitlines()
            if json.loads(line)["event"] == "done"}
    assert done == set(report["stages"])  # its stages reported to the progress file the go line named
    # the same run as `inbetween run`: a run of the same shot afterwards finds every stage fresh, the same frames
    assert main(["run", str(small_shot), "--out", str(tmp_path / "again")]) == 0
    again = json.loads((tmp_path / "again" / "report.json").read_text())
    assert not [n for n, s in again["stages"].items() if not s["cached"]]
    assert again["frames_version"] == report["frames_version"]
    np.testing.assert_array_equal(frames_of(tmp_path / "again"), frames_of(tmp_path / "out"))


@pytest.mark.slow  # the standby imports Dagster and the stages before it says ready
def test_a_standby_told_nothing_exits_untouched(home, small_shot, tmp_path):
    proc = standby(small_shot, tmp_path / "out")
    output, _ = proc.communicate("", timeout=300)
    assert proc.returncode == 0 and output.strip().splitlines()[-1] == "ready"
    assert not (tmp_path / "out").exists() and not (home / "storage").exists() and not (home / "shots.json").exists()


@pytest.mark.slow  # the standby imports Dagster and the stages before it reads its line
def test_a_standby_given_a_line_that_is_no_json_object_says_so_and_runs_nothing(home, small_shot, tmp_path):
    proc = standby(small_shot, tmp_path / "out")
    output, _ = proc.communicate("[1, 2]\n", timeout=300)
    assert proc.returncode == 2 and "not a JSON object" in output
    assert not (tmp_path / "out").exists() and not (home / "storage").exists()
