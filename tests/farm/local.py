"""A farm on this machine: Postgres, Redis and `inbetween worker` processes, configured as docs/production.md says.

The instance's dagster.yaml is the one printed in docs/production.md, read
from it verbatim, so the documented configuration is the tested one.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from .servers import postgres, redis

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs" / "production.md"


def docs_block(first_line: str) -> str:
    """The fenced block of docs/production.md whose first line is `first_line`."""
    blocks = DOCS.read_text().split("```")[1::2]  # inside the fences
    for block in blocks:
        body = block.split("\n", 1)[1] if "\n" in block else ""
        if body.startswith(first_line):
            return body
    raise LookupError(f"docs/production.md has no block starting with {first_line!r}")


@dataclass
class Worker:
    name: str
    proc: subprocess.Popen
    log: Path
    progress: Path

    def events(self) -> list[dict]:
        """Stage events this worker emitted (assets/progress.py)."""
        try:
            return [json.loads(line) for line in self.progress.read_text().splitlines() if line.strip()]
        except FileNotFoundError:
            return []

    def tail(self, n: int = 30) -> str:
        return "\n".join(self.log.read_text(errors="replace").splitlines()[-n:])


@dataclass
class LocalFarm:
    """Environment of every farm process, and the workers started so far."""

    root: Path
    env: dict[str, str]
    postgres_url: str
    visibility_timeout: float
    workers: list[Worker] = field(default_factory=list)

    def cli(self, *args: str, timeout: float = 600) -> subprocess.CompletedProcess:
        """`inbetween ARGS` in a new process with the farm's environment."""
        return subprocess.run([sys.executable, "-m", "assets.cli", *args], env=self.env, cwd=ROOT, text=True,
                              capture_output=True, timeout=timeout)

    def start_worker(self, name: str, queues: tuple[str, ...] = ("cpu",), threads: int = 1) -> Worker:
        log, progress = self.root / f"{name}.log", self.root / f"{name}.progress.jsonl"
        env = {**self.env, "INBETWEEN_PROGRESS": str(progress)}
        args = [sys.executable, "-m", "assets.cli", "worker", "--name", f"{name}@%h", "--threads", str(threads),
                "--visibility-timeout", str(self.visibility_timeout)]
        for q in queues:
            args += ["--queue", q]
        with open(log, "w") as f:
            proc = subprocess.Popen(args, env=env, cwd=ROOT, stdout=f, stderr=subprocess.STDOUT)
        worker = Worker(name, proc, log, progress)
        self.workers.append(worker)
        return worker

    def wait_ready(self, seconds: float = 180) -> None:
        """Until every worker listens on the broker (Celery logs 'NAME@HOST ready.')."""
        deadline = time.time() + seconds
        pending = list(self.workers)
        while pending and time.time() < deadline:
            for w in list(pending):
                if w.proc.poll() is not None:
                    raise RuntimeError(f"worker {w.name} exited with {w.proc.returncode}:\n{w.tail()}")
                if " ready." in w.log.read_text(errors="replace"):
                    pending.remove(w)
            time.sleep(0.5)
        if pending:
            raise RuntimeError(f"workers not ready after {seconds:.0f} s: {[w.name for w in pending]}")

    def stop(self) -> None:
        for w in self.workers:
            if w.proc.poll() is None:
                w.proc.send_signal(signal.SIGTERM)  # warm shutdown: finish the current step, take no other
        for w in self.workers:
            try:
                w.proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                w.proc.kill()
                w.proc.wait()


@contextmanager
def local_farm(root: Path, visibility_timeout: float = 60.0) -> Iterator[LocalFarm]:
    """Postgres + Redis on 127.0.0.1, an INBETWEEN_HOME under root whose dagster.yaml is the documented one."""
    with ExitStack() as stack:
        pg_url = stack.enter_context(postgres())
        broker = stack.enter_context(redis())
        home = root / "home"
        (home / "dagster").mkdir(parents=True, exist_ok=True)
        (home / "dagster" / "dagster.yaml").write_text(docs_block("# $DAGSTER_HOME/dagster.yaml"))
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep),
               "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster"), "INBETWEEN_BROKER": broker,
               # SQLAlchemy 2.1 maps a bare postgresql:// to psycopg 3; dagster-postgres ships psycopg2
               "INBETWEEN_POSTGRES_URL": pg_url.replace("postgresql://", "postgresql+psycopg2://", 1),
               "INBETWEEN_SHOTS": str(root / "shots")}
        env.pop("INBETWEEN_PROGRESS", None)
        farm = LocalFarm(root, env, pg_url, visibility_timeout)
        stack.callback(farm.stop)
        yield farm
