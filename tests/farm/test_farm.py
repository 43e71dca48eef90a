"""The farm against real servers: PostgreSQL storage, a Redis broker, two `inbetween worker` processes.

One local farm for the module (tests/farm/local.py): the batch runs once, and
the tests after it look at what it left (its outputs, its runs in
PostgreSQL, the UI's view of them); the last test kills a worker.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from assets.graph import shot_graph
from tests.assets.conftest import SAMPLES, scaled_copy

from .local import ROOT, local_farm
from .servers import free_port

STAGES = shot_graph(2).stages

pytestmark = [pytest.mark.slow, pytest.mark.timeout(1800)]  # the first test sets up two batches
EXTRA = "the farm extra (pip install -e '.[farm]'), which .ci/run installs"
pytest.importorskip("dagster_celery", reason=EXTRA)
psycopg2 = pytest.importorskip("psycopg2", reason=EXTRA)

SHOTS = ("arm_cross", "legs_cross", "two_poses")
KILLED_STAGE = "seg0/rife_matrix"  # the longest stage: a kill lands in its middle on any machine


def small_copy(name: str, dst: Path) -> Path:
    """A sample at half size with every other pose (5 frames): the farm's steps, fast."""
    d = scaled_copy(SAMPLES / name, dst, 0.5)
    data = json.loads((d / "shot.json").read_text())
    if "frames" in data:
        data["frames"] = 5
    else:
        data["poses"] = data["poses"][::2]
    (d / "shot.json").write_text(json.dumps(data))
    return d


def stage_hashes(home: Path, partition: str) -> dict[str, str]:
    """Content hash of every stage output of a shot (resources/store.py meta.json)."""
    return {n: json.loads((home / "storage" / partition / n / "meta.json").read_text())["hash"] for n in STAGES}


def frame_bytes(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "frames").glob("*.png"))}


def runs_in_postgres(url: str) -> list[tuple[str, str, str]]:
    """(run id, job name, status) of every run the instance recorded, read with psycopg2."""
    with psycopg2.connect(url) as conn, conn.cursor() as cur:
        cur.execute("SELECT run_id, pipeline_name, status FROM runs ORDER BY create_timestamp")
        return cur.fetchall()


def _check(proc: subprocess.CompletedProcess, farm=None) -> subprocess.CompletedProcess:
    logs = "".join(f"\n--- {w.name}\n{w.tail()}" for w in (farm.workers if farm else []))
    assert proc.returncode == 0, f"exit {proc.returncode}\n{proc.stdout}\n{proc.stderr[-4000:]}{logs}"
    return proc


@pytest.fixture(scope="module")
def shots(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("farm") / "shots"
    for name in SHOTS:
        small_copy(name, root / name)
    return root


@pytest.fixture(scope="module")
def reference(shots, tmp_path_factory) -> Path:
    """The in-process batch of the same shots, in its own home (SQLite): what the farm must reproduce."""
    tmp = tmp_path_factory.mktemp("reference")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "INBETWEEN_HOME": str(tmp / "home"),
           "DAGSTER_HOME": str(tmp / "home" / "dagster")}
    _check(subprocess.run([sys.executable, "-m", "assets.cli", "batch", str(shots), "--out", str(tmp / "out")],
                          env=env, cwd=ROOT, capture_output=True, text=True, timeout=900))
    return tmp


@pytest.fixture(scope="module")
def farm(shots):
    # longer than any stage of these small shots, even on a loaded machine; the kill test waits about this long
    with local_farm(shots.parent, visibility_timeout=30.0) as farm:
        farm.start_worker("w1")
        farm.start_worker("w2")
        farm.wait_ready()
        yield farm


@pytest.fixture(scope="module")
def farm_batch(farm, shots):
    """`inbetween batch SHOTS --out OUT --executor celery`, every shot in flight at once."""
    out = shots.parent / "out"
    start = time.perf_counter()
    proc = _check(farm.cli("batch", str(shots), "--out", str(out), "--executor", "celery",
                           "--workers", str(len(SHOTS))), farm)
    assert "no `inbetween worker` answered" not in proc.stderr  # both idle workers answered the ping
    return out, proc, time.perf_counter() - start


def test_batch_through_two_workers_matches_the_in_process_run(farm, farm_batch, reference):
    out, proc, seconds = farm_batch
    home = Path(farm.env["INBETWEEN_HOME"])
    for name in SHOTS:
        assert frame_bytes(out / name) == frame_bytes(reference / "out" / name), name
        assert stage_hashes(home, name) == stage_hashes(reference / "home", name), name
        report = json.loads((out / name / "report.json").read_text())
        assert all(s["executed"] and not s["cached"] for s in report["stages"].values()), report["stages"]
    # the steps were shared between the two worker processes
    done = {w.name: {(e["partition"], e["stage"]) for e in w.events() if e["event"] == "done"} for w in farm.workers}
    assert all(done.values()), done
    assert set().union(*done.values()) == {(name, n) for name in SHOTS for n in STAGES}
    # and Dagster recorded one successful run of the farm job per shot in PostgreSQL
    runs = runs_in_postgres(farm.postgres_url)
    assert [(job, status) for _, job, status in runs] == [("inbetween_shot_farm", "SUCCESS")] * len(SHOTS)
    print(f"farm batch of {len(SHOTS)} shots: {seconds:.1f} s")


def test_unchanged_rerun_through_the_farm_executes_no_stage(farm, farm_batch, shots):
    before = runs_in_postgres(farm.postgres_url)
    steps_before = [len(w.events()) for w in farm.workers]
    out = shots.parent / "out-rerun"
    _check(farm.cli("batch", str(shots), "--out", str(out), "--executor", "celery"), farm)
    for name in SHOTS:
        report = json.loads((out / name / "report.json").read_text())
        assert not any(s["executed"] for s in report["stages"].values()), report["stages"]
        assert frame_bytes(out / name) == frame_bytes(farm_batch[0] / name)
    assert runs_in_postgres(farm.postgres_url) == before  # no run was even started
    assert [len(w.events()) for w in farm.workers] == steps_before  # no worker got a step


def test_forced_farm_run_of_an_unchanged_shot_finds_every_stage_cached(farm, farm_batch, shots, monkeypatch):
    """A run launched anyway (the UI materializing the job): every step runs on a worker, none computes."""
    home = Path(farm.env["INBETWEEN_HOME"])
    for key in ("INBETWEEN_HOME", "DAGSTER_HOME", "INBETWEEN_BROKER", "INBETWEEN_POSTGRES_URL", "INBETWEEN_SHOTS"):
        monkeypatch.setenv(key, farm.env[key])
    from assets.run import execute, plan
    from ops.settings import Settings

    stages = ["key0/masks", "key1/template", "seg0/rife_matrix", "inbetween_frames"]  # both lanes and the blending
    meta = home / "storage" / SHOTS[0]
    mtimes = {n: (meta / n / "meta.json").stat().st_mtime_ns for n in stages}
    timings = execute(plan(shots / SHOTS[0]), Settings(), stages, executor="celery")
    assert set(timings) == set(stages) and all(t["cached"] for t in timings.values()), timings
    assert {n: (meta / n / "meta.json").stat().st_mtime_ns for n in stages} == mtimes  # nothing rewritten


QUERY = """{ runsOrError { __typename ... on Runs { results {
  runId jobName status tags { key value } } } } }"""


def test_ui_graphql_on_the_postgres_instance_lists_the_batch_runs(farm, farm_batch):
    port = free_port()
    exe = Path(sys.executable).parent / "dagster-webserver"
    log = farm.root / "webserver.log"
    with open(log, "w") as f:
        proc = subprocess.Popen([str(exe), "-h", "127.0.0.1", "-p", str(port), "-w", str(ROOT / "workspace.yaml")],
                                cwd=ROOT, env=farm.env, stdout=f, stderr=subprocess.STDOUT)
    try:
        runs, deadline = None, time.time() + 240
        while runs is None and time.time() < deadline:
            try:
                req = urllib.request.Request(f"http://127.0.0.1:{port}/graphql", headers={"Content-Type": "application/json"},
                                             data=json.dumps({"query": QUERY}).encode())
                with urllib.request.urlopen(req, timeout=20) as r:
                    data = json.loads(r.read())["data"]["runsOrError"]
                assert data["__typename"] == "Runs", data
                runs = data["results"]
            except OSError:
                time.sleep(1)
        assert runs is not None, f"webserver did not answer:\n{log.read_text()[-3000:]}"
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
    in_postgres = {run_id for run_id, _, _ in runs_in_postgres(farm.postgres_url)}
    batch = [r for r in runs if r["jobName"] == "inbetween_shot_farm"]
    assert {r["runId"] for r in runs} == in_postgres
    partitions = sorted({t["key"]: t["value"] for t in r["tags"]}["dagster/partition"] for r in batch
                        if r["status"] == "SUCCESS")
    assert set(SHOTS) <= set(partitions)


def test_worker_killed_mid_stage_the_run_completes_on_the_other(farm, farm_batch, reference, shots):
    """SIGKILL the worker running rife_matrix: its unacknowledged step goes back to the queue after the
    visibility timeout, the other worker runs it, and the outputs are those of the in-process run."""
    home = Path(farm.env["INBETWEEN_HOME"])
    shutil.rmtree(home / "storage" / SHOTS[0] / KILLED_STAGE)  # a lost output: the next run recomputes it, and below
    seen = {w.name: len(w.events()) for w in farm.workers}
    new_events = lambda w: [e for e in w.events()[seen[w.name]:] if e["partition"] == SHOTS[0] and e["stage"] == KILLED_STAGE
                             and e["event"] != "progress"]  # rife_matrix reports its progress between start and done
    out = shots.parent / "out-kill"
    batch = subprocess.Popen([sys.executable, "-m", "assets.cli", "batch", str(shots), "--out", str(out),
                              "--executor", "celery"], env=farm.env, cwd=ROOT, text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    victim, deadline = None, time.time() + 600
    while victim is None and time.time() < deadline and batch.poll() is None:
        victim = next((w for w in farm.workers if any(e["event"] == "start" for e in new_events(w))), None)
        time.sleep(0.05)
    assert victim is not None, f"no worker started {KILLED_STAGE}: {batch.communicate()}"
    victim.proc.send_signal(signal.SIGKILL)
    victim.proc.wait()
    killed_at = time.time()
    stdout, stderr = batch.communicate(timeout=600)
    assert batch.returncode == 0, stdout + stderr
    survivor = next(w for w in farm.workers if w is not victim)
    assert [e["event"] for e in new_events(victim)] == ["start"]  # killed in the middle: it never finished
    assert [(e["event"], e.get("cached")) for e in new_events(survivor)] == [("start", None), ("done", False)]
    report = json.loads((out / SHOTS[0] / "report.json").read_text())
    assert report["stages"][KILLED_STAGE]["executed"] and not report["stages"][KILLED_STAGE]["cached"]
    assert frame_bytes(out / SHOTS[0]) == frame_bytes(reference / "out" / SHOTS[0])
    assert stage_hashes(home, SHOTS[0]) == stage_hashes(reference / "home", SHOTS[0])
    print(f"run completed {time.time() - killed_at:.1f} s after the kill (visibility timeout {farm.visibility_timeout} s)")
