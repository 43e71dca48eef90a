"""Incremental reruns of an edited shot in the background, followed stage by stage: the editor's, and those of
`inbetween watch` (assets/run/watch.py).

A rerun is `python -m assets.cli run SHOT --out OUT` in a subprocess, so the front end stays responsive and
always runs the code on disk. While nothing runs, the next rerun waits ready as a *standby*
(assets/standby.py): a process that has already imported Dagster and the stages, started the worker
processes, opened the instance and loaded the network, and runs the shot as saved when a rerun is asked for
(a key1 T-junction edit of arm_cross: Save to frames a fifth to a quarter shorter). A standby whose code
changed on disk since it started is dropped for a fresh process. The subprocess appends every stage event to
a progress file (INBETWEEN_PROGRESS, assets/progress.py), which this module tails into the status the front
end shows.

One rerun at a time. A rerun asked for while one runs *supersedes* it: the running one is stopped at once
and the new one starts. Nothing is lost: every stage output is written atomically with its provenance, so
the stages the stopped run finished are reused when their inputs did not change, and the shot's lock
(assets/run/) is released when the old process exits.

The status is kept in WORKDIR/rerun.json. An editor restarted while a rerun runs follows that process to
its end; if the process died with the editor, the rerun starts again.
"""
from __future__ import annotations

import copy
import itertools
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from ..codeversion import project_fingerprint

STATES = ("idle", "running", "done", "failed")
POLL_S = 0.2
KILL_GRACE_S = 5.0
RELEASE_S = 60.0  # a dropped standby still there after this long is killed
STANDBY_SWITCH = "INBETWEEN_STANDBY"  # "0": no standby (each rerun a fresh process; it holds ~0.5 GB while it waits)


def stale(root: Path, fingerprint: str) -> bool:
    """Whether the project's sources under `root` differ from those whose project_fingerprint was `fingerprint`
    (taken before a standby started): that standby would run old code."""
    return project_fingerprint(root) != fingerprint


def _alive(pid: int, marker: str) -> bool:
    """Whether process pid runs and its command line contains `marker` (a reused pid does not count)."""
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, PermissionError):
        return False
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        if stat.rsplit(")", 1)[1].split()[0] == "Z":
            return False
        return marker in Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return True  # no /proc: trust kill(0)


def error_line(log: Path) -> str:
    """The one-line error the CLI printed (its `error: ...` line), else the log's last line."""
    try:
        lines = [ln.strip() for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return "the rerun stopped without a log"
    errors = [ln for ln in lines if ln.startswith("error: ")]
    if errors:
        return errors[-1].removeprefix("error: ")
    return lines[-1] if lines else "the rerun stopped without a message"


class Reruns:
    """The rerun of one shot: request, status, follow. Thread-safe; one worker thread owns the subprocess."""

    def __init__(self, shot_dir: Path, partition: str, workdir: Path, home: Path, cwd: Path,
                 command: list[str] | None = None, standby_command: list[str] | None = None,
                 out_dir: Path | None = None):
        """command: what runs the shot (default `python -m assets.cli run SHOT --out OUT`); standby_command: the
        same made ready ahead (default with the default command: `python -m assets.standby run ...`; none with a
        command of the caller's unless given); out_dir: the OUT the command writes (default WORKDIR/out)."""
        self.shot_dir, self.partition, self.workdir = Path(shot_dir), partition, Path(workdir)
        self.out_dir = Path(out_dir) if out_dir is not None else self.workdir / "out"
        self.home, self.cwd = Path(home), Path(cwd)
        self.command = command or [sys.executable, "-m", "assets.cli", "run", str(self.shot_dir), "--out", str(self.out_dir)]
        if standby_command is None and command is None and os.environ.get(STANDBY_SWITCH, "1") != "0":
            standby_command = [sys.executable, "-m", "assets.standby", *self.command[3:]]
        self.standby_command = standby_command
        self._standby: dict | None = None  # {"proc", "log", "code"} of the standby process, if one waits
        self._standbys = itertools.count(1)
        self._cond = threading.Condition()
        # running_stage: the stage started last of those still running (several run at once: two lanes, and
        # stages computed ahead of the steps that report them); stage_progress: its {"stage", "done", "bound"}
        # when it reports them (rife_matrix counts its blends);
        # last_seconds: what each stage took when it last ran, across reruns (the panel's estimate)
        self._status = {"state": "idle", "stages": {}, "error": None, "seq": 0, "running_stage": None,
                        "running_since": None, "running": {}, "stage_progress": None, "last_seconds": {},
                        "reason": None, "note": None, "started": None, "finished": None, "frames_version": None}
        self._private: dict = {}  # pid, progress, log of the current rerun
        self._version = 0
        self._pending = False
        self._adopt = False
        self._stop = False
        self._thread = threading.Thread(target=self._worker, name="rerun", daemon=True)
        self._load()

    # ------------------------------------------------------------ public

    def start(self) -> None:
        self._thread.start()

    def stop(self, cancel: bool = False) -> None:
        """Stop following (the editor's server shuts down): a running rerun finishes on its own and the next editor
        follows it; with `cancel` (`inbetween watch` ended by Ctrl-C) it is stopped too."""
        with self._cond:
            self._stop = True
            self._cond.notify_all()
            standby, self._standby = self._standby, None
            pid = self._private.get("pid") if cancel and self._status["state"] == "running" else None
        if standby is not None:
            _release(standby["proc"])
        if pid:
            self._kill(int(pid), None)

    def request(self, reason: str) -> int:
        """Ask for a rerun; from this call on the status describes it (state running). Returns its number."""
        with self._cond:
            seq = self._status["seq"] + 1
            self._status.update(state="running", stages={}, error=None, seq=seq, running_stage=None, running_since=None,
                                running={}, stage_progress=None, reason=reason, note=None, started=time.time(), finished=None)
            self._pending = True
            self._changed()
            self._cond.notify_all()
            return seq

    def snapshot(self) -> tuple[int, dict]:
        """(change counter, status dict as GET /api/status returns it)."""
        with self._cond:
            return self._version, {**copy.deepcopy(self._status), "log": self._private.get("log")}

    def wait_idle(self, timeout: float) -> dict:
        """Block until the state is not running (tests, benchmarks); returns the status."""
        end = time.time() + timeout
        with self._cond:
            while self._status["state"] == "running" and time.time() < end:
                self._cond.wait(0.1)
            return copy.deepcopy(self._status)

    # ------------------------------------------------------------ persistence

    def _changed(self) -> None:
        """Count a change and persist the status (call with the lock held)."""
        self._version += 1
        self.workdir.mkdir(parents=True, exist_ok=True)
        tmp = self.workdir / f"rerun.json.tmp{os.getpid()}"
        tmp.write_text(json.dumps({**self._status, **self._private}))
        os.replace(tmp, self.workdir / "rerun.json")

    def _load(self) -> None:
        try:
            data = json.loads((self.workdir / "rerun.json").read_text())
        except (OSError, ValueError):
            return
        self._status.update({k: data[k] for k in self._status if k in data})
        self._private = {k: data[k] for k in ("pid", "progress", "log") if k in data}
        if self._status["state"] != "running":
            return
        pid = self._private.get("pid")
        if pid and _alive(int(pid), str(self.out_dir)):
            self._adopt = True
            self._status["note"] = "followed after the editor restarted"
        else:  # the rerun died with the previous editor: the saved shot still needs it
            self.request("restart: the previous rerun was interrupted")

    # ------------------------------------------------------------ worker

    def _worker(self) -> None:
        if self._adopt:
            self._follow(self._status["seq"], int(self._private["pid"]), None)
        while True:
            with self._cond:
                idle = not self._pending and not self._stop
            if idle:
                self._prepare_standby()  # nothing runs: the next rerun gets ready meanwhile
            with self._cond:
                while not self._pending and not self._stop:
                    self._cond.wait()
                if self._stop:
                    return
                self._pending = False
                seq = self._status["seq"]
            self._spawn_and_follow(seq)

    def _env(self) -> dict:
        return {**os.environ, "INBETWEEN_HOME": str(self.home), "PYTHONUNBUFFERED": "1"}

    def _prepare_standby(self) -> None:
        """Start the standby process for the next rerun, unless one waits or this editor runs its own command."""
        if self.standby_command is None or (self._standby is not None and self._standby["proc"].poll() is None):
            return
        self.workdir.mkdir(parents=True, exist_ok=True)
        log = self.workdir / f"standby-{next(self._standbys)}.log"
        code = project_fingerprint(self.cwd)  # before its imports: a source saved while it imports makes it stale
        env = {k: v for k, v in self._env().items() if k != "INBETWEEN_PROGRESS"}
        with open(log, "wb") as logf:
            proc = subprocess.Popen(self.standby_command, stdout=logf, stderr=subprocess.STDOUT, stdin=subprocess.PIPE,
                                    env=env, cwd=self.cwd, start_new_session=True)
        with self._cond:
            if self._stop:
                _release(proc)
            else:
                self._standby = {"proc": proc, "log": log, "code": code}

    def _take_standby(self, progress: Path) -> tuple[subprocess.Popen, Path] | None:
        """The waiting standby, told to run now and report to `progress`; None when there is none that can."""
        with self._cond:
            standby, self._standby = self._standby, None
        if standby is None:
            return None
        proc = standby["proc"]
        if proc.poll() is not None or stale(self.cwd, standby["code"]):
            _release(proc)
            return None
        try:
            proc.stdin.write((json.dumps({"INBETWEEN_PROGRESS": str(progress)}) + "\n").encode())
            proc.stdin.close()
        except OSError:  # it died meanwhile
            _release(proc)
            return None
        return proc, standby["log"]

    def _spawn_and_follow(self, seq: int) -> None:
        self.workdir.mkdir(parents=True, exist_ok=True)
        progress, log = self.workdir / f"progress-{seq}.jsonl", self.workdir / f"rerun-{seq}.log"
        progress.unlink(missing_ok=True)
        taken = self._take_standby(progress)
        if taken is not None:
            proc, log = taken
        else:
            with open(log, "wb") as logf:
                # own session: Ctrl-C on the editor does not reach it, and a stop kills its whole group
                proc = subprocess.Popen(self.command, stdout=logf, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                        env={**self._env(), "INBETWEEN_PROGRESS": str(progress)}, cwd=self.cwd,
                                        start_new_session=True)
        with self._cond:
            self._private = {"pid": proc.pid, "progress": str(progress), "log": str(log)}
            if self._status["seq"] == seq:
                self._changed()
        self._follow(seq, proc.pid, proc)

    def _follow(self, seq: int, pid: int, proc: subprocess.Popen | None) -> None:
        """Tail the rerun's progress until it exits, is superseded, or the server stops."""
        progress, log = Path(self._private["progress"]), Path(self._private["log"])
        offset = 0
        while True:
            rc = proc.poll() if proc is not None else (None if _alive(pid, str(self.out_dir)) else -1)
            offset = self._read_progress(seq, progress, offset)
            if rc is not None:
                break
            with self._cond:
                if self._stop:
                    return
                if self._pending:  # superseded by a newer save
                    superseded = True
                else:
                    superseded = False
                    self._cond.wait(POLL_S)
            if superseded:
                self._kill(pid, proc)
                return
            self._note_waiting(seq, log)
        self._finish(seq, rc if proc is not None else None, log)

    def _read_progress(self, seq: int, path: Path, offset: int) -> int:
        """Apply the complete JSON lines appended since offset; returns the new offset."""
        try:
            with open(path, "rb") as f:
                f.seek(offset)
                chunk = f.read()
        except OSError:
            return offset
        end = chunk.rfind(b"\n") + 1
        with self._cond:
            if self._status["seq"] != seq:
                return offset + end
            for line in chunk[:end].splitlines():
                try:
                    ev = json.loads(line)
                except ValueError:
                    continue
                if ev.get("partition") != self.partition:
                    continue
                self._apply(ev)
            if end:
                self._changed()
        return offset + end

    def _apply(self, ev: dict) -> None:
        """Take one progress event of this rerun (call with the lock held)."""
        st, stage, kind = self._status, ev.get("stage"), ev.get("event")
        if kind == "start":
            st["running"][stage] = ev.get("time", time.time())
            if st["stage_progress"] and st["stage_progress"]["stage"] == stage:
                st["stage_progress"] = None
        elif kind == "done":
            st["stages"][stage] = {"cached": bool(ev["cached"]), "seconds": ev["seconds"]}
            if not ev["cached"]:
                st["last_seconds"][stage] = ev["seconds"]
            st["running"].pop(stage, None)
        elif kind == "progress" and stage in st["running"]:
            st["stage_progress"] = {"stage": stage, "done": ev.get("done"), "bound": ev.get("bound")}
        # a stage's "done" may come while a later one runs: the panel names the one started last
        latest = max(st["running"], key=st["running"].get, default=None)
        st["running_stage"], st["running_since"] = latest, st["running"].get(latest)

    def _note_waiting(self, seq: int, log: Path) -> None:
        """Say so when the CLI waits for another run of this shot (it prints `waiting: ...`)."""
        try:
            waiting = b"waiting:" in log.read_bytes()[-4096:]
        except OSError:
            return
        with self._cond:
            note = "waiting for another run of this shot to finish" if waiting else self._status["note"]
            if self._status["seq"] == seq and self._status["state"] == "running" and note != self._status["note"]:
                self._status["note"] = note
                self._changed()

    def _finish(self, seq: int, rc: int | None, log: Path) -> None:
        """Final state from the exit status (None: adopted, unknown) and the report the CLI wrote."""
        report_path = self.out_dir / "report.json"
        with self._cond:
            started = self._status["started"] or 0
            try:
                fresh = report_path.stat().st_mtime >= started - 1
                report = json.loads(report_path.read_text()) if fresh else None
            except (OSError, ValueError):
                report = None
            ok = report is not None and (rc == 0 if rc is not None else "error: " not in _tail(log))
            if self._status["seq"] != seq:
                return
            if ok:
                self._status["last_seconds"].update({n: s["seconds"] for n, s in report["stages"].items() if not s["cached"]})
                self._status.update(state="done", error=None, frames_version=report.get("frames_version"),
                                    stages={n: {"cached": bool(s["cached"]), "seconds": s["seconds"]}
                                            for n, s in report["stages"].items()})
            else:
                self._status.update(state="failed", error=error_line(log))
            self._status.update(running_stage=None, running_since=None, running={}, stage_progress=None, finished=time.time())
            self._changed()
            self._cond.notify_all()

    def _kill(self, pid: int, proc: subprocess.Popen | None) -> None:
        """Stop a superseded rerun and its children (its own process group), then wait for it to exit."""
        for sig, grace in ((signal.SIGTERM, KILL_GRACE_S), (signal.SIGKILL, KILL_GRACE_S)):
            try:
                os.killpg(pid, sig)
            except ProcessLookupError:
                break
            end = time.time() + grace
            while time.time() < end:
                gone = proc.poll() is not None if proc is not None else not _alive(pid, str(self.out_dir))
                if gone:
                    return
                time.sleep(0.05)


def _release(proc: subprocess.Popen) -> None:
    """Let a standby go without waiting for it: at the end of its input it exits untouched, once its imports are
    done (killing it meanwhile could interrupt the instance making a new home's tables); reaped on a thread of
    its own, killed if it is still there after RELEASE_S."""
    try:
        proc.stdin.close()
    except OSError:
        pass

    def reap() -> None:
        try:
            proc.wait(RELEASE_S)
        except subprocess.TimeoutExpired:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.wait()

    threading.Thread(target=reap, name="standby-reaper", daemon=True).start()


def _tail(log: Path, size: int = 4096) -> str:
    try:
        return log.read_bytes()[-size:].decode(errors="replace")
    except OSError:
        return ""
