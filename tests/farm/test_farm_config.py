"""The farm's configuration without servers: queue routing, the documented run config, the step lock."""
from __future__ import annotations

import subprocess
import sys
import textwrap
import time

import pytest
import yaml

from assets.farm.settings import CPU_QUEUE, GPU_QUEUE, queue_for
from assets.graph import EVAL_STAGES, union_graph
from ops.shotio.load import MAX_KEYS

from .local import ROOT, docs_block

pytest.importorskip("dagster_celery", reason="the farm extra (pip install -e '.[farm]'), which .ci/run installs")


def _queues(device: str) -> dict[str, str]:
    """Queue of every step of the farm job, as the executor routes it."""
    from assets.definitions import farm_job

    job = farm_job()
    return {"/".join(node.name.split("__")): queue_for(node.definition.required_resource_keys, device)
            for node in job.graph.nodes}


def test_rife_matrix_goes_to_gpu_only_with_cuda():
    on_gpu = _queues("cuda")
    # the segments' frames may run the network too (the keys' interpolation where neither lane is reliable)
    assert {n for n, q in on_gpu.items() if q == GPU_QUEUE} == {f"seg{s}/{name}" for s in range(MAX_KEYS - 1)
                                                               for name in ("rife_matrix", "frames")}
    assert set(_queues("cpu").values()) == {CPU_QUEUE}
    assert set(on_gpu) == set(union_graph()) - set(EVAL_STAGES)  # every stage of any shot, the evaluation aside


def test_documented_run_config_is_valid_for_the_farm_job(monkeypatch):
    import dagster as dg

    from assets.definitions import farm_job

    monkeypatch.setenv("INBETWEEN_BROKER", "redis://127.0.0.1:6379/0")
    config = yaml.safe_load(docs_block("# run config of inbetween_shot_farm"))
    assert config["execution"]["config"]["broker"] == {"env": "INBETWEEN_BROKER"}
    dg.validate_run_config(farm_job(), config)
    with pytest.raises(dg.DagsterInvalidConfigError):
        dg.validate_run_config(farm_job(), {"execution": {"config": {"brokr": "redis://x"}}})


@pytest.mark.slow  # seconds, not milliseconds: the whole suite runs it, the edit loop does not
def test_a_second_delivery_of_a_step_waits_for_the_first(tmp_path, monkeypatch):
    """Two workers given the same task id: the second runs only once the first has released it."""
    from assets.farm.worker import hold_step, release_step

    monkeypatch.setenv("INBETWEEN_HOME", str(tmp_path))
    hold_step(task_id="t1")
    second = textwrap.dedent("""
        import os, time
        from assets.farm import worker
        worker.hold_step(task_id="t1")
        live = os.fstat(worker._held["t1"].fileno()).st_ino == os.stat(worker._step_lock_path("t1")).st_ino
        print(time.time(), live)
    """)
    proc = subprocess.Popen([sys.executable, "-c", second], cwd=ROOT, text=True, stdout=subprocess.PIPE,
                            env={"PYTHONPATH": str(ROOT), "INBETWEEN_HOME": str(tmp_path), "PATH": ""})
    with pytest.raises(subprocess.TimeoutExpired):
        proc.wait(timeout=3)  # still waiting while the first holds the step
    released = time.time()
    release_step(task_id="t1")
    out, _ = proc.communicate(timeout=60)
    acquired, live = out.split()
    assert proc.returncode == 0 and float(acquired) >= released
    assert live == "True"  # it holds the lock file now at the path, not the one the first holder removed
