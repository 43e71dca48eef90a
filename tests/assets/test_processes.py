"""The stages' worker processes (assets/processes.py): ops run there, errors come back, a crash is one error, and
a shot computed with them gives byte-identical outputs to one computed on threads."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import assets.processes as processes
from ops.cputime import charged
from ops.errors import ShotError


def test_an_op_runs_in_another_process_and_returns_its_result():
    pid = processes.run(os.getpid)
    assert pid != os.getpid()
    assert processes.run(divmod, 17, 5) == (3, 2)


def test_an_ops_error_comes_back_as_itself():
    with pytest.raises(ShotError, match="shot.json: poses"):
        processes.run(_raise_shot_error)


def _raise_shot_error():
    raise ShotError("shot.json", "poses", "bad", "fix it")


class _Unpicklable(Exception):
    def __init__(self, a, b):
        super().__init__(f"{a} and {b}")


def _raise_unpicklable():
    raise _Unpicklable("this", "that")


def test_an_error_that_cannot_be_pickled_comes_back_as_its_message():
    with pytest.raises(RuntimeError, match="_Unpicklable: this and that"):
        processes.run(_raise_unpicklable)
    assert processes.run(divmod, 7, 2) == (3, 1)  # the pool is not broken


def test_a_worker_that_dies_is_one_error_and_the_next_op_gets_a_new_pool():
    with pytest.raises(RuntimeError, match="_crash.*died"):
        processes.run(_crash)
    assert processes.run(divmod, 7, 2) == (3, 1)


def _crash():
    os.kill(os.getpid(), signal.SIGKILL)


def _spin(seconds: float) -> float:
    start = time.process_time()
    while time.process_time() - start < seconds:
        pass
    return seconds


def test_a_workers_cpu_seconds_count_for_the_thread_that_called_it_alone():
    # a stage's cpu_seconds (report.json) is its thread's CPU plus its calls' in the workers
    before, here = charged(), time.thread_time()
    processes.run(_spin, 0.3)
    spent = charged() - before
    assert 0.3 <= spent < 3.0
    assert time.thread_time() - here < 0.15  # waiting for the worker costs this thread next to nothing
    other = []
    thread = threading.Thread(target=lambda: other.append((processes.run(_spin, 0.1), charged())))
    thread.start()
    thread.join()
    assert 0.1 <= other[0][1] < 1.0  # the other thread's call counts for it
    assert charged() - before == spent  # and not for this one


def test_switched_off_every_op_runs_here(monkeypatch):
    monkeypatch.setenv(processes.ENV_SWITCH, "0")
    assert processes.pool() is None
    assert processes.run(os.getpid) == os.getpid()


@pytest.mark.slow  # two cold runs of a half-size shot
def test_processes_and_threads_compute_the_same_outputs(home, small_shot, tmp_path, monkeypatch):
    """Every stage's data version (the content hash of its output) is the same whichever way the ops ran."""
    from assets.run.execute import run_shot

    versions = []
    for switch in ("1", "0"):
        monkeypatch.setenv(processes.ENV_SWITCH, switch)
        monkeypatch.setenv("INBETWEEN_HOME", str(tmp_path / f"home{switch}"))
        monkeypatch.setenv("DAGSTER_HOME", str(tmp_path / f"home{switch}" / "dagster"))
        report = run_shot(small_shot, tmp_path / f"out{switch}")
        assert all(s["executed"] for s in report["stages"].values())
        meta = {}
        storage = tmp_path / f"home{switch}" / "storage" / report["partition"]
        for f in sorted(storage.rglob("meta.json")):
            meta[str(f.parent.relative_to(storage))] = json.loads(f.read_text())["hash"]
        versions.append(meta)
    assert versions[0] and versions[0] == versions[1]


def test_a_command_that_leaves_while_its_workers_start_exits_at_once_and_cleanly():
    """A quick command leaves (assets/run/leave.py: exit handlers, no finalization) while the pool's thread is still
    forking its workers: every worker is waited for and terminated, none is left to fail on its own, and the exit
    does not wait on a worker that waits for work (that hung a test's CLI run until its timeout)."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    code = ("import assets.processes as p\nfrom assets.run.leave import leave\np.pool()\nleave(0)\n")
    env = {k: v for k, v in os.environ.items() if k != "INBETWEEN_PROCESSES"}
    for ignore_sigterm in (False, True, False):  # True: as under nohup or a scheduler, the workers inherit SIG_IGN

        def dispositions(ignore=ignore_sigterm):
            signal.signal(signal.SIGTERM, signal.SIG_IGN if ignore else signal.SIG_DFL)

        out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=60,
                             env=env, preexec_fn=dispositions)
        assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr[-2000:]


def test_large_arguments_and_results_travel_as_files_that_are_removed_once_read():
    big = np.arange(processes.SPILL_BYTES // 4, dtype=np.float64).reshape(-1, 2)  # 2x SPILL_BYTES pickled
    out = processes.run(_scaled, big, factor=3.0)
    np.testing.assert_array_equal(out, big * 3.0)
    folder = processes._spill_folder()
    assert folder.is_dir() and not any(folder.iterdir())  # both files read and removed
    assert folder.stat().st_mode & 0o077 == 0  # no other user can put a pickle there
    assert processes.run(divmod, 7, 2) == (3, 1)  # small ones through the pipe


def _scaled(a, factor):
    assert a.nbytes > processes.SPILL_BYTES
    return a * factor


def test_a_spill_folder_of_a_process_that_is_gone_is_removed_by_the_next_one(tmp_path, monkeypatch):
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    base = processes._spill_folder().parent
    stale = base / f"{processes.SPILL_PREFIX}{int(gone.stdout)}-test"
    stale.mkdir()
    (stale / "x.pickle").write_bytes(b"left by a killed run")
    monkeypatch.setattr(processes, "_spill_dir", None)
    mine = processes._spill_folder()
    try:
        assert not stale.exists() and mine.is_dir()
    finally:
        shutil.rmtree(mine)  # the process's own folder is put back by monkeypatch


_WARM_UP_AND_LEAVE = """
import multiprocessing.forkserver, os, sys
from assets import processes
processes.warm_up()
print(multiprocessing.forkserver._forkserver._forkserver_pid, flush=True)
os._exit(0)  # as a command that computed nothing leaves (assets/run/leave.py)
"""


def test_a_warmed_up_fork_server_ends_by_itself_when_its_process_has():
    """`inbetween run` starts the fork server before it plans; a run with nothing to compute never starts a pool,
    and must leave no process behind it."""
    import time

    done = subprocess.run([sys.executable, "-c", _WARM_UP_AND_LEAVE], capture_output=True, text=True, timeout=60,
                          cwd=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    pid = int(done.stdout.split()[-1])
    deadline = time.monotonic() + 30  # it finishes its imports first (a second or two)
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.1)
    raise AssertionError(f"the fork server {pid} outlived its process by 30 s")


_WARM_UP_THEN_POOL = """
import multiprocessing.forkserver, os
from assets import processes
processes.warm_up()
server = multiprocessing.forkserver._forkserver._forkserver_pid
print(server, processes.run(os.getppid), flush=True)
"""


def test_a_pool_after_a_warm_up_forks_its_workers_from_that_server():
    done = subprocess.run([sys.executable, "-c", _WARM_UP_THEN_POOL], capture_output=True, text=True, timeout=120,
                          cwd=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    server, parent = done.stdout.split()
    assert server == parent, done.stderr


def test_a_workers_warning_goes_where_its_parents_go(tmp_path):
    """The CLI sends warnings to INBETWEEN_HOME/logs/warnings.log; a lane's worker process did not, and numpy's
    RuntimeWarning from a worker reached the terminal during `inbetween eval`."""
    log = tmp_path / "warnings.log"
    code = ("import os, sys, warnings\n"
            "import assets.processes as processes\n"
            "from assets.warning_log import route_warnings\n"
            "route_warnings(sys.argv[1])\n"
            "processes.run(warnings.warn, 'a warning in a worker', RuntimeWarning)\n"
            "processes.shutdown()\n"
            "print(os.getpid())\n")
    out = subprocess.run([sys.executable, "-c", code, str(log)], capture_output=True, text=True, timeout=120,
                         check=True, env={**os.environ, processes.ENV_SWITCH: "1"})
    assert "a warning in a worker" not in out.stderr
    lines = [ln for ln in log.read_text().splitlines() if "a warning in a worker" in ln]
    assert len(lines) == 1 and lines[0].split()[2] != out.stdout.strip()  # logged by the worker, not the parent
