"""Reruns across an editor restart: a live rerun is followed to its end, a dead one is started again."""
from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from assets.run.reruns import Reruns, error_line

from .conftest import fake_command


def make(tmp_path, *extra) -> Reruns:
    work = tmp_path / "work"
    return Reruns(tmp_path / "shot", "shot", work, tmp_path / "home", tmp_path, fake_command("shot", work / "out", *extra))


@pytest.mark.slow  # seconds, not milliseconds: the whole suite runs it, the edit loop does not
def test_restarted_editor_follows_a_rerun_that_still_runs(tmp_path):
    # 2 s a stage: the rerun (four stages) must outlast the editor's restart even on a loaded machine
    first = make(tmp_path, "--sleep", "2.0")
    first.start()
    first.request("save")
    time.sleep(0.8)  # the rerun is under way
    first.stop()  # the editor goes away; the rerun does not
    pid = json.loads((tmp_path / "work" / "rerun.json").read_text())["pid"]
    second = make(tmp_path, "--sleep", "2.0")
    assert second.snapshot()[1]["state"] == "running" and second.snapshot()[1]["seq"] == 1
    second.start()
    st = second.wait_idle(60)
    assert st["state"] == "done" and st["seq"] == 1 and "restarted" in st["note"]
    assert set(st["stages"]) == {"key1/refined_masks", "key1/template", "seg0/rife_matrix", "inbetween_frames"}
    assert json.loads((tmp_path / "work" / "rerun.json").read_text())["pid"] == pid  # no second process started


def test_restarted_editor_reruns_when_the_rerun_died_with_it(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    work = tmp_path / "work"
    work.mkdir()
    (work / "rerun.json").write_text(json.dumps({"state": "running", "seq": 4, "stages": {}, "pid": dead.pid,
                                                 "progress": str(work / "p.jsonl"), "log": str(work / "l.log")}))
    reruns = make(tmp_path)
    st = reruns.snapshot()[1]
    assert st["state"] == "running" and st["seq"] == 5 and st["reason"].startswith("restart")
    reruns.start()
    assert reruns.wait_idle(20)["state"] == "done"


def test_error_line_is_the_cli_one_liner(tmp_path):
    log = tmp_path / "log"
    log.write_text("some dagster noise\nerror: /s/shot.json: poses[2].t: bad; fix: sort\n")
    assert error_line(log) == "/s/shot.json: poses[2].t: bad; fix: sort"
    log.write_text("Traceback...\nKeyError: 'x'\n")
    assert error_line(log) == "KeyError: 'x'"


def test_the_running_stage_stays_named_while_earlier_steps_report_and_shows_its_progress(tmp_path):
    """Work-ahead order: rife_matrix (here the last stage) starts while the steps before it still report "done";
    the status names it the whole time, with its progress, and remembers what each stage took."""
    reruns = make(tmp_path, "--ahead", "--sleep", "0.3")
    reruns.start()
    reruns.request("save")
    seen = []
    while (st := reruns.snapshot()[1])["state"] == "running":
        seen.append((st["running_stage"], st["stage_progress"], dict(st["stages"])))
        time.sleep(0.03)
    assert st["state"] == "done"
    last = "inbetween_frames"
    # from the first "done" of an earlier step until the last stage's own "done": it is named
    after = [(r, p) for r, p, done in seen if done and last not in done]
    assert after and all(r == last for r, _ in after), after
    progress = [p for _, p in after if p]
    assert progress and progress[-1] == {"stage": last, "done": 3, "bound": 4}
    assert all(p["done"] <= p["bound"] for p in progress)
    assert st["running_stage"] is None and st["stage_progress"] is None
    assert st["last_seconds"][last] == 0.03 and "key1/refined_masks" not in st["last_seconds"]  # cached: not timed


def make_ready(tmp_path, *extra) -> Reruns:
    """Reruns whose next rerun waits ready as a standby (fake_run.py --standby plays assets/standby.py)."""
    work = tmp_path / "work"
    command = fake_command("shot", work / "out", *extra)
    return Reruns(tmp_path / "shot", "shot", work, tmp_path / "home", tmp_path, command,
                  standby_command=[*command, "--standby"])


def wait_ready(reruns: Reruns, not_pid: int | None = None, timeout: float = 30.0) -> dict:
    """The standby that waits, once it has said `ready` (one other than not_pid)."""
    end = time.time() + timeout
    while time.time() < end:
        standby = reruns._standby
        if standby is not None and standby["proc"].pid != not_pid and "ready" in standby["log"].read_text():
            return standby
        time.sleep(0.05)
    raise AssertionError("no standby got ready")


def test_a_save_runs_in_the_standby_that_waited_and_the_next_one_gets_ready(tmp_path):
    reruns = make_ready(tmp_path)
    reruns.start()
    standby = wait_ready(reruns)
    reruns.request("save")
    st = reruns.wait_idle(30)
    # its stages reached the editor: the progress file came with the go line
    assert st["state"] == "done" and set(st["stages"]) == {"key1/refined_masks", "key1/template",
                                                           "seg0/rife_matrix", "inbetween_frames"}
    record = json.loads((tmp_path / "work" / "rerun.json").read_text())
    assert record["pid"] == standby["proc"].pid and record["log"] == str(standby["log"])
    assert not list((tmp_path / "work").glob("rerun-*.log"))  # no other process ran it
    following = wait_ready(reruns, not_pid=standby["proc"].pid)
    reruns.stop()  # the editor goes: the waiting standby ends at the end of its input, having run nothing
    assert following["proc"].wait(10) == 0
    assert following["log"].read_text().strip() == "ready"


def test_a_standby_whose_code_changed_is_dropped_for_a_fresh_run(tmp_path):
    code = tmp_path / "ops" / "x.py"
    code.parent.mkdir()
    code.write_text("")
    reruns = make_ready(tmp_path)
    reruns.start()
    standby = wait_ready(reruns)
    code.write_text("x = 1\n")  # saved after the standby imported the code
    reruns.request("save")
    assert reruns.wait_idle(30)["state"] == "done"
    record = json.loads((tmp_path / "work" / "rerun.json").read_text())
    assert record["pid"] != standby["proc"].pid and record["log"] == str(tmp_path / "work" / "rerun-1.log")
    assert standby["proc"].wait(10) == 0 and standby["log"].read_text().strip() == "ready"  # ran nothing
    reruns.stop()


@pytest.mark.slow  # seconds: a rerun long enough to be superseded
def test_a_save_while_the_standby_runs_stops_it_and_runs_the_new_save(tmp_path):
    # 2 s a stage: the first save's run must still be going when the second save comes, on a loaded machine too
    # (at 1 s it once ended first during the whole suite, and the standby exited 0 before it could be stopped)
    reruns = make_ready(tmp_path, "--sleep", "2.0")
    reruns.start()
    standby = wait_ready(reruns)
    first = reruns.request("save")
    end = time.time() + 30
    while "key1/refined_masks" not in reruns.snapshot()[1]["running"] and time.time() < end:
        time.sleep(0.05)  # the standby runs the first save
    second = reruns.request("save again")
    assert standby["proc"].wait(15) != 0  # stopped: its process group killed
    st = reruns.wait_idle(60)
    assert st["state"] == "done" and st["seq"] == second == first + 1 and st["reason"] == "save again"
    assert json.loads((tmp_path / "work" / "rerun.json").read_text())["pid"] != standby["proc"].pid
    reruns.stop()
