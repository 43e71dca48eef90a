"""Throwaway servers on 127.0.0.1 for the farm tests and benchmark: a PostgreSQL cluster and a Redis broker.

Both live in a temporary directory, listen on a free port and are removed on exit.
PostgreSQL refuses to run as root, so as root the cluster belongs to the
`postgres` user that Debian's package creates.
"""
from __future__ import annotations

import glob
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _pg_bin(name: str) -> str:
    """A PostgreSQL server program: on PATH, else Debian's /usr/lib/postgresql/<newest>/bin."""
    found = shutil.which(name) or next(iter(sorted(glob.glob(f"/usr/lib/postgresql/*/bin/{name}"), reverse=True)), None)
    if not found:
        raise RuntimeError(f"{name} not found: install PostgreSQL (apt-get install postgresql)")
    return found


def _wait_port(port: int, seconds: float, what: str) -> None:
    deadline = time.time() + seconds
    while time.time() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=1):
                return
        except OSError:
            time.sleep(0.2)
    raise RuntimeError(f"{what} did not listen on 127.0.0.1:{port} within {seconds:.0f} s")


@contextmanager
def postgres() -> Iterator[str]:
    """A fresh cluster with database `dagster`; yields its URL (trust auth, 127.0.0.1 only)."""
    root = Path(tempfile.mkdtemp(prefix="inbetween-pg-"))
    as_root = os.geteuid() == 0
    owner = pwd.getpwnam("postgres") if as_root else pwd.getpwuid(os.geteuid())
    os.chown(root, owner.pw_uid, owner.pw_gid)
    prefix = ["runuser", "-u", owner.pw_name, "--"] if as_root else []
    data, port = root / "data", free_port()
    run = lambda *cmd: subprocess.run([*prefix, *cmd], check=True, capture_output=True, text=True)
    try:
        run(_pg_bin("initdb"), "-D", str(data), "-U", "inbetween", "--auth=trust", "--no-sync", "-E", "UTF8")
        run(_pg_bin("pg_ctl"), "-D", str(data), "-l", str(root / "server.log"), "-w", "-t", "60", "start",
            "-o", f"-h 127.0.0.1 -p {port} -k {root} -c fsync=off -c max_connections=200")
        try:
            run(_pg_bin("createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", "inbetween", "dagster")
            yield f"postgresql://inbetween@127.0.0.1:{port}/dagster"
        finally:
            run(_pg_bin("pg_ctl"), "-D", str(data), "-m", "immediate", "-w", "stop")
    finally:
        shutil.rmtree(root, ignore_errors=True)


@contextmanager
def redis() -> Iterator[str]:
    """A Redis server without persistence; yields its URL."""
    exe = shutil.which("redis-server")
    if not exe:
        raise RuntimeError("redis-server not found: apt-get install redis-server")
    root, port = Path(tempfile.mkdtemp(prefix="inbetween-redis-")), free_port()
    with open(root / "redis.log", "w") as log:
        proc = subprocess.Popen([exe, "--bind", "127.0.0.1", "--port", str(port), "--save", "", "--appendonly", "no",
                                 "--dir", str(root)], stdout=log, stderr=subprocess.STDOUT)
    try:
        _wait_port(port, 30, "redis-server")
        yield f"redis://127.0.0.1:{port}/0"
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        shutil.rmtree(root, ignore_errors=True)
