"""Fixtures of the editor tests: small shots, an in-process server with a stand-in rerun command, and for the
browser tests a warm pipeline run, a real `inbetween edit` subprocess and Debian's Chromium through Playwright."""
from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from tests.assets.conftest import SAMPLES, scaled_copy

ROOT = Path(__file__).resolve().parents[2]
FAKE_RUN = Path(__file__).with_name("fake_run.py")
ARTIFACTS = Path(__file__).with_name("artifacts")
CHROMIUM = os.environ.get("INBETWEEN_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
                 "--no-first-run"]


def env_for(home: Path) -> dict:
    """Environment of a subprocess using `home` as INBETWEEN_HOME and running this tree's code."""
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return {**os.environ, "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster"), "PYTHONPATH": path}


def call(url: str, method: str = "GET", body: bytes | None = None, headers: dict | None = None):
    """(status, headers, body bytes) of one HTTP request; error statuses are returned, not raised."""
    req = urllib.request.Request(url, data=body, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def call_json(url: str, method: str = "GET", data=None):
    body = json.dumps(data).encode() if data is not None else None
    status, _, raw = call(url, method, body, {"Content-Type": "application/json"})
    return status, json.loads(raw) if raw else None


@pytest.fixture
def home(tmp_path, monkeypatch):
    h = tmp_path / "home"
    monkeypatch.setenv("INBETWEEN_HOME", str(h))
    monkeypatch.setenv("DAGSTER_HOME", str(h / "dagster"))
    return h


@pytest.fixture
def small_shot(tmp_path):
    """arm_cross at half size (192 px): no manual masks, T-junctions on key1."""
    return scaled_copy(SAMPLES / "arm_cross", tmp_path / "shots" / "arm_cross", 0.5)


class InProcessServer:
    """The editor app served by uvicorn in a thread of the test process."""

    def __init__(self, state):
        import uvicorn

        from editor.server import bind, build_app

        sock = bind(0)
        self.port = sock.getsockname()[1]
        self.url = f"http://127.0.0.1:{self.port}"
        self.state = state
        self.server = uvicorn.Server(uvicorn.Config(build_app(state, self.port), log_level="warning", lifespan="on"))
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [sock]}, daemon=True)
        self.thread.start()
        while not self.server.started:
            time.sleep(0.02)

    def close(self):
        self.server.should_exit = True
        self.thread.join(10)


def fake_command(partition: str, out: Path, *extra: str) -> list[str]:
    return [sys.executable, str(FAKE_RUN), partition, str(out), *extra]


@pytest.fixture
def serve(home):
    """serve(shot_dir, *fake_run_args) -> a running InProcessServer whose reruns are fake_run.py."""
    from assets.home import home as home_dir
    from editor.state import EditorState

    servers = []

    def start(shot_dir: Path, *extra: str) -> InProcessServer:
        out = home_dir() / "editor" / Path(shot_dir).name / "out"
        state = EditorState(shot_dir, rerun_command=fake_command(Path(shot_dir).name, out, *extra), url="test")
        servers.append(InProcessServer(state))
        return servers[-1]

    yield start
    for s in servers:
        s.close()
        _stop_rerun(s.state.workdir)


def _stop_rerun(workdir: Path) -> None:
    """Stop the rerun a test's editor left running (its process group, by the pid the editor recorded)."""
    try:
        data = json.loads((workdir / "rerun.json").read_text())
    except (OSError, ValueError):
        return
    pid = data.get("pid")
    if data.get("state") == "running" and pid:
        try:
            os.killpg(int(pid), signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass


# ---------------------------------------------------------------- browser tests


@pytest.fixture(scope="session")
def warm_shot(tmp_path_factory) -> Path:
    """A half-size arm_cross run once through the whole pipeline (about a minute); tests copy it."""
    base = tmp_path_factory.mktemp("warm")
    shot = scaled_copy(SAMPLES / "arm_cross", base / "shots" / "arm_cross", 0.5)
    subprocess.run([sys.executable, "-m", "assets.cli", "run", str(shot), "--out", str(base / "out")],
                   env=env_for(base / "home"), cwd=ROOT, check=True, capture_output=True, timeout=600)
    return base


@pytest.fixture
def warm_copy(warm_shot, tmp_path) -> tuple[Path, Path]:
    """(shot_dir, home): a private copy of the warm shot and its store, every stage fresh."""
    shutil.copytree(warm_shot / "shots", tmp_path / "shots")
    shutil.copytree(warm_shot / "home", tmp_path / "home", ignore=shutil.ignore_patterns("locks", "editor"))
    shot = tmp_path / "shots" / "arm_cross"
    (tmp_path / "home" / "shots.json").write_text(json.dumps({"arm_cross": str(shot)}))
    return shot, tmp_path / "home"


@pytest.fixture
def editor_process(warm_copy):
    """`inbetween edit SHOT --port 0 --no-browser` as a subprocess: yields (url, shot_dir, home)."""
    shot, home = warm_copy
    proc = subprocess.Popen([sys.executable, "-m", "assets.cli", "edit", str(shot), "--port", "0", "--no-browser"],
                            env=env_for(home), cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    line = proc.stdout.readline()
    m = re.search(r"http://127\.0\.0\.1:\d+", line)
    assert m, f"the editor did not start: {line}{proc.stdout.read() if proc.poll() is not None else ''}"
    yield m.group(0), shot, home
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(15)
    except subprocess.TimeoutExpired:
        proc.kill()
    _stop_rerun(home / "editor" / "arm_cross")


@pytest.fixture(scope="session")
def browser():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture
def open_page(browser, request):
    """open_page(url, height=820) -> the editor page at url, loaded (the in-process server of `serve` will do: no
    pipeline run needed); a screenshot of each is kept in tests/editor/artifacts/<test>[-n].png."""
    pages, errors = [], []

    def start(url: str, height: int = 820, width: int = 1500):
        pg = browser.new_page(viewport={"width": width, "height": height})
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(url + "/")
        pg.wait_for_selector("body[data-ready='1']", timeout=60_000)
        pages.append(pg)
        return pg

    yield start
    ARTIFACTS.mkdir(exist_ok=True)
    for i, pg in enumerate(pages):
        pg.screenshot(path=str(ARTIFACTS / f"{request.node.name}{f'-{i}' if i else ''}.png"))
        pg.close()
    assert not errors, f"errors in the page: {errors}"


@pytest.fixture
def page(browser, editor_process, request):
    """The editor page, loaded; a screenshot of it is kept in tests/editor/artifacts/<test>.png."""
    url, _, _ = editor_process
    pg = browser.new_page(viewport={"width": 1500, "height": 820})
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto(url + "/")
    pg.wait_for_selector("body[data-ready='1']", timeout=60_000)
    yield pg
    ARTIFACTS.mkdir(exist_ok=True)
    pg.screenshot(path=str(ARTIFACTS / f"{request.node.name}.png"))
    pg.close()
    assert not errors, f"errors in the page: {errors}"
