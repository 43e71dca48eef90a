"""`inbetween watch` (assets/run/watch.py): a save reruns the shot, a bad save says why and keeps watching, a
kill ends it with its reruns."""
from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from assets.run.watch import files_state

ROOT = Path(__file__).resolve().parents[2]


def test_files_state_sees_a_save_but_not_the_runs_own_writes(tmp_path):
    shot = tmp_path / "shot"
    (shot / "masks").mkdir(parents=True)
    (shot / "shot.json").write_text("{}")
    (shot / "masks" / "key0_occlusion_0.png").write_bytes(b"x")
    out, home = shot / "out", shot / ".inbetween"
    before = files_state(shot, (out.resolve(),))
    out.mkdir()
    (out / "report.json").write_text("{}")  # the run's output inside the shot folder: not a save
    home.mkdir()
    (home / "x").write_text("")  # a hidden folder (a home beside the shot): not a save
    (shot / ".shot.json.swp").write_text("")  # an editor's swap file: not a save
    assert files_state(shot, (out.resolve(),)) == before
    (shot / "masks" / "key0_occlusion_0.png").write_bytes(b"xy")  # a mask repainted
    assert files_state(shot, (out.resolve(),)) != before


def _lines(proc: subprocess.Popen) -> queue.Queue:
    q: queue.Queue = queue.Queue()

    def pump():
        for line in proc.stdout:
            q.put(line.rstrip("\n"))
        q.put(None)

    threading.Thread(target=pump, daemon=True).start()
    return q


def _expect(q: queue.Queue, prefix: str, timeout: float = 240.0) -> str:
    end = time.time() + timeout
    while time.time() < end:
        try:
            line = q.get(timeout=1.0)
        except queue.Empty:
            continue
        assert line is not None, f"watch ended before printing {prefix!r}"
        if line.startswith(prefix):
            return line
    raise AssertionError(f"no {prefix!r} line within {timeout} s")


def _report(out: Path) -> dict:
    return json.loads((out / "report.json").read_text())


def _save(shot: Path, edit) -> None:
    data = json.loads((shot / "shot.json").read_text())
    edit(data)
    (shot / "shot.json").write_text(json.dumps(data, indent=1))


@pytest.mark.slow  # real runs: the first, an edit in the standby, a bad save, its fix
def test_watch_reruns_each_save_and_ends_with_its_reruns(home, small_shot, tmp_path):
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "assets.cli", "watch", str(small_shot), "--out", str(out)],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        q = _lines(proc)
        _expect(q, "watching ")
        assert "(15 ran, 0 cached)" in _expect(q, "start: done")
        first = _report(out)["frames_version"]

        def move(data):
            x, y = data["t_junctions"][1][0]
            data["t_junctions"][1][0] = [x + 2.0, y]

        _save(small_shot, move)
        line = _expect(q, "saved: ")
        assert line.startswith("saved: done") and "0 cached" not in line, line  # only what the save changed ran
        assert _report(out)["frames_version"] != first
        ran = [log.name for log in (home / "watch").glob("*/standby-*.log")]
        assert len(ran) >= 2  # the saves ran in standbys made ready while nothing ran

        text = (small_shot / "shot.json").read_text()
        (small_shot / "shot.json").write_text(text[: len(text) // 2])  # saved half-written
        line = _expect(q, "saved: ")
        assert line.startswith("saved: failed") and "shot.json" in line, line  # says what is wrong, keeps watching
        (small_shot / "shot.json").write_text(text)
        assert _expect(q, "saved: ").startswith("saved: done")

        proc.send_signal(signal.SIGTERM)
        assert _expect(q, "stopped", 30)
        assert proc.wait(30) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    # its standby ends once it reads the end of its input; nothing of the watch is left running
    end = time.time() + 60
    while time.time() < end and _running(str(out)):
        time.sleep(0.5)
    assert not _running(str(out))


def _running(marker: str) -> list[int]:
    """Pids of processes whose command line names `marker`."""
    found = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            cmd = (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            state = (proc / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if marker in cmd and state != "Z":
            found.append(int(proc.name))
    return found
