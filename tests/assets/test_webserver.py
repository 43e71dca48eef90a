"""The Definitions load in dagster-webserver and its GraphQL API shows the graph of docs/design.md."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from assets.graph import union_graph, union_sources

ROOT = Path(__file__).resolve().parents[2]
QUERY = "{ assetNodes { assetKey { path } dependencyKeys { path } } }"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_graphql_asset_nodes_match_design(home):
    port = _free_port()
    (home / "dagster").mkdir(parents=True)
    env = {**os.environ, "DAGSTER_HOME": str(home / "dagster")}
    exe = Path(sys.executable).parent / "dagster-webserver"
    proc = subprocess.Popen([str(exe), "-h", "127.0.0.1", "-p", str(port), "-w", str(ROOT / "workspace.yaml")],
                            cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        nodes = None
        deadline = time.time() + 180
        while time.time() < deadline and nodes is None:
            try:
                req = urllib.request.Request(f"http://127.0.0.1:{port}/graphql", data=json.dumps({"query": QUERY}).encode(),
                                             headers={"Content-Type": "application/json"})
                with urllib.request.urlopen(req, timeout=10) as r:
                    data = json.loads(r.read())
                if data.get("data", {}).get("assetNodes"):
                    nodes = data["data"]["assetNodes"]
            except OSError:
                time.sleep(1)
        assert nodes is not None, "webserver did not answer"
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
    graph = {"/".join(n["assetKey"]["path"]): {"/".join(d["path"]) for d in n["dependencyKeys"]} for n in nodes}
    expected = {name: set(parents) for name, parents in union_graph().items()} | {s: set() for s in union_sources()}
    assert graph == expected


@pytest.mark.slow
def test_inbetween_ui_starts_its_own_dagster_without_the_venv_on_path(home):
    """`.venv/bin/inbetween ui` with the venv not activated: Dagster comes from the interpreter's environment."""
    import signal

    port = _free_port()
    env = {k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"}
    env["PATH"] = "/usr/bin:/bin"
    exe = Path(sys.executable).parent / "inbetween"
    proc = subprocess.Popen([str(exe), "ui", "--port", str(port)], cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, start_new_session=True)
    try:
        answered, deadline = False, time.time() + 240
        while time.time() < deadline and not answered and proc.poll() is None:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/server_info", timeout=10) as r:
                    answered = r.status == 200
            except OSError:
                time.sleep(1)
        assert answered, f"inbetween ui did not serve: {proc.poll()} {proc.stderr.read(2000) if proc.poll() else ''}"
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
