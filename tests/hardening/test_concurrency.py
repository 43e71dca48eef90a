"""Concurrency (issue 10): two runs of one shot at once, a batch while the shot is saved, a locked SQLite."""
from __future__ import annotations

import fcntl
import json
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import assets.run.session as runs
from assets.run import run_shot

from .conftest import ROOT, SHOT, env_for

pytestmark = pytest.mark.slow


def _nudge_t_junction(shot: Path) -> None:
    """Move a key1 T-junction by a pixel: key1's lane from the refined masks on, and RIFE, must run again."""
    data = json.loads((shot / "shot.json").read_text())
    k = 1 if data["t_junctions"][1] else 0
    x, y = data["t_junctions"][k][0]
    data["t_junctions"][k][0] = [x + 1.0, y]
    (shot / "shot.json").write_text(json.dumps(data))


def _start(home: Path, *args: str, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "assets.cli", *args], env=env or env_for(home), cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _held(lock: Path) -> bool:
    """Whether another process holds the flock of this lock file."""
    if not lock.exists():
        return False
    with open(lock, "a") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        fcntl.flock(f, fcntl.LOCK_UN)
        return False


def _wait_for(predicate, seconds: float, proc: subprocess.Popen | None = None) -> None:
    deadline = time.time() + seconds
    while not predicate():
        assert time.time() < deadline, "timed out"
        assert proc is None or proc.poll() is None, proc.communicate()
        time.sleep(0.05)


def test_two_runs_of_one_shot_at_once_both_succeed_with_identical_frames(warm, tmp_path):
    _nudge_t_junction(warm.shot)
    first = _start(warm.home, "run", str(warm.shot), "--out", str(tmp_path / "a"))
    _wait_for(lambda: _held(warm.home / "locks" / f"{warm.partition}.lock"), 300, first)
    second = _start(warm.home, "run", str(warm.shot), "--out", str(tmp_path / "b"))
    out_a, err_a = first.communicate(timeout=1800)
    out_b, err_b = second.communicate(timeout=1800)
    assert first.returncode == 0 and second.returncode == 0, (err_a, err_b)
    assert "waiting: another run of" in err_b and "waiting" not in err_a
    assert "Traceback" not in err_a + err_b and "error:" not in err_a + err_b
    frames_a = sorted((tmp_path / "a" / "frames").glob("*.png"))
    frames_b = sorted((tmp_path / "b" / "frames").glob("*.png"))
    assert len(frames_a) == 3 and [f.read_bytes() for f in frames_a] == [f.read_bytes() for f in frames_b]
    report_b = json.loads((tmp_path / "b" / "report.json").read_text())
    assert not any(s["executed"] for s in report_b["stages"].values())  # the second found the first's outputs


def test_batch_while_the_shot_is_edited_and_saved(warm, tmp_path):
    _nudge_t_junction(warm.shot)
    events = tmp_path / "progress.jsonl"
    env = {**env_for(warm.home), "INBETWEEN_PROGRESS": str(events)}
    proc = _start(warm.home, "batch", str(warm.shot.parent), "--out", str(tmp_path / "out"), env=env)

    def stage_done() -> bool:
        text = events.read_text() if events.exists() else ""
        return '"event": "done"' in text and "refined_masks" in text

    _wait_for(stage_done, 600, proc)
    data = json.loads((warm.shot / "shot.json").read_text())
    data["frames"] = 4
    text = json.dumps(data)
    with open(warm.shot / "shot.json", "w") as f:  # saved the plain way: truncated, then written in two parts
        f.write(text[: len(text) // 2])
        f.flush()
        time.sleep(0.05)
        f.write(text[len(text) // 2:])
    out, err = proc.communicate(timeout=2400)
    assert proc.returncode == 0, err
    assert "Traceback" not in err and "error:" not in err
    row = out.splitlines()[2].split()
    assert row[0] == SHOT and row[1] == "4" and row[-1] == "ok"
    assert len(list((tmp_path / "out" / SHOT / "frames").glob("*.png"))) == 4
    assert json.loads((tmp_path / "out" / SHOT / "report.json").read_text())["frames"] == 4


def test_database_is_locked_is_retried_and_never_shown(warm, tmp_path, monkeypatch, capfd):
    db = sqlite3.connect(warm.home / "dagster" / "history" / "runs.db", timeout=30, isolation_level=None,
                         check_same_thread=False)
    released = threading.Event()

    def release() -> None:
        if not released.is_set():
            released.set()
            db.execute("COMMIT")

    seen = []
    real = runs._database_locked

    def spy(e):  # the run hit the lock: let the other writer finish a moment later
        locked = real(e)
        seen.append(locked)
        if locked:
            threading.Timer(0.5, release).start()
        return locked

    monkeypatch.setattr(runs, "_database_locked", spy)
    warm.forget_dagster_record()  # so the run writes to the Dagster instance
    db.execute("BEGIN EXCLUSIVE")  # another process writing the instance, for longer than SQLite waits (5 s)
    safety = threading.Timer(300.0, release)
    safety.start()
    try:
        report = run_shot(warm.shot, tmp_path / "out")
    finally:
        safety.cancel()
        release()
        db.close()
    assert any(seen), "the lock was never hit: the test did not test the retry"
    assert report["frames"] == 3 and all(s["cached"] for s in report["stages"].values())
    captured = capfd.readouterr()
    assert "locked" not in captured.out + captured.err


def _children(pid: int) -> list[int]:
    """Process ids whose parent is pid (from /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def test_a_batch_worker_that_dies_is_one_failed_shot(warm, tmp_path):
    import os
    import signal

    _nudge_t_junction(warm.shot)
    events = tmp_path / "progress.jsonl"
    env = {**env_for(warm.home), "INBETWEEN_PROGRESS": str(events)}
    proc = _start(warm.home, "batch", str(warm.shot.parent), "--out", str(tmp_path / "out"), env=env)
    _wait_for(lambda: events.exists() and '"event": "start"' in events.read_text(), 600, proc)
    workers = [p for p in _children(proc.pid) if b"spawn_main" in Path(f"/proc/{p}/cmdline").read_bytes()]
    assert workers
    for pid in workers:  # killed as the OOM killer would
        os.kill(pid, signal.SIGKILL)
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 1 and "Traceback" not in err, err
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "worker process died" in errors[0] and "fix: rerun" in errors[0]
    assert out.splitlines()[2].split()[-1] == "failed"


def _open_fresh_instance(home: str) -> str:
    """In a new process: open the Dagster instance of a fresh INBETWEEN_HOME; 'ok' or the error's first words."""
    import os

    os.environ["INBETWEEN_HOME"] = home
    os.environ.pop("DAGSTER_HOME", None)
    from assets.home import ensure_home
    from assets.run.session import open_instance

    ensure_home()
    try:
        open_instance()
        return "ok"
    except Exception as e:  # the property under test: no process fails
        return f"{type(e).__name__}: {str(e)[:120]}"


def test_processes_opening_a_new_home_at_once_all_succeed(tmp_path):
    """Batch workers start together on a fresh home: each would create the SQLite tables, and all but the first
    failed with "table jobs already exists" until opening the instance took a lock."""
    import multiprocessing as mp

    for round_ in range(2):
        home = tmp_path / f"home{round_}"
        # closed and joined, not left to Pool.__exit__'s terminate(): a loaded suite once hung there for good, a
        # worker alive in its task queue's lock that the SIGTERM did not end and terminate() then joined forever
        pool = mp.get_context("spawn").Pool(4)
        try:
            assert pool.map(_open_fresh_instance, [str(home)] * 4) == ["ok"] * 4
        finally:
            pool.close()
            pool.join()
