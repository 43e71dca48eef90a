"""The cached asset graph end to end: caching, incremental recompute, crash safety, bad input."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from assets.cli import main
from assets.graph import shot_graph
from assets.run import run_shot

from .conftest import frames_of

STAGES, PARENTS = shot_graph(2).stages, shot_graph(2).parents

pytestmark = pytest.mark.slow


def executed(report: dict) -> set[str]:
    return {n for n, s in report["stages"].items() if not s["cached"]}


def test_run_writes_contract_outputs_and_second_run_is_cached(home, small_shot, tmp_path, monkeypatch):
    from assets.run.staging import PREFIX, StagedOutputs

    handed = []  # the staged folders run_shot put in place (written while Dagster recorded the last steps)
    folder = StagedOutputs.folder
    monkeypatch.setattr(StagedOutputs, "folder", lambda self, v: handed.append(folder(self, v)) or handed[-1])
    out = tmp_path / "out"
    first = run_shot(small_shot, out)
    assert executed(first) == set(STAGES)
    assert len(handed) == 1 and handed[0] is not None and not list(out.glob(f"{PREFIX}*"))
    shot = json.loads((small_shot / "shot.json").read_text())
    n = len(shot["poses"]) if "frames" not in shot else shot["frames"]
    frames = frames_of(out)
    assert frames.shape[0] == n == first["frames"]
    assert frames.shape[3] == 4 and frames.shape[1:3] == (192, 192)
    report = json.loads((out / "report.json").read_text())
    assert report["frames"] == n and len(report["times"]) == n and set(report["stages"]) == set(STAGES)
    # each stage's own CPU seconds, its worker calls' included (the template's cut search runs in a worker)
    cpu = {name: st["cpu_seconds"] for name, st in report["stages"].items()}
    assert all(c >= 0 for c in cpu.values()) and cpu["key1/template"] > 0.01 and cpu["seg0/key0/deformed_frames"] > 0.01
    # each lane's agreement with the other key, as its deformed_frames stage measured it (docs/lanes.md)
    agreement = report["segments"][0]["lane_agreement_db"]
    assert set(agreement) == {"key0->key1", "key1->key0"} and all(20 < v < 60 for v in agreement.values())
    assert "lane_agreement_db" not in report["path"]
    # a side stage recomputed alone from the stored parents (benchmarks/bench_lanes.py) is what the run stored
    from benchmarks.bench_pipeline import compute_alone
    from resources.store import Store

    alone, _ = compute_alone(home, small_shot, "seg0/key1/deformed_frames")
    assert alone.metadata["agreement_db"] == agreement["key1->key0"]
    stored = Store(home / "storage").read("seg0/key1/deformed_frames", "arm_cross")
    np.testing.assert_array_equal(alone.value.images, stored.images)
    # the output's first and last frames are the keyframes (issue 8: >= 40 dB composited over white)
    from ops.evaluation.metrics import psnr
    from ops.shotio.image_io import read_image

    for i, key in ((0, "key0.png"), (-1, "key1.png")):
        assert psnr(frames[i], read_image(small_shot / key)) >= 40.0
    second = run_shot(small_shot, tmp_path / "out2")
    assert executed(second) == set() and second["segments"][0]["lane_agreement_db"] == agreement
    assert all(s["cached"] and s["cpu_seconds"] == 0 for s in second["stages"].values())
    np.testing.assert_array_equal(frames_of(tmp_path / "out2"), frames)


def test_editing_key1_t_junctions_recomputes_exactly_downstream(home, small_shot, tmp_path):
    run_shot(small_shot, tmp_path / "out")
    data = json.loads((small_shot / "shot.json").read_text())
    assert data["t_junctions"][1], "the sample must have T-junctions in key1"
    data["t_junctions"][1][0] = [data["t_junctions"][1][0][0] + 1.0, data["t_junctions"][1][0][1]]
    (small_shot / "shot.json").write_text(json.dumps(data))
    report = run_shot(small_shot, tmp_path / "out")
    ran = executed(report)
    for untouched in ("key0/masks", "key0/refined_masks", "key0/template", "key1/masks"):
        assert untouched not in ran
    assert "key1/refined_masks" in ran
    # everything that ran is downstream of key1/t_junctions
    down = {"key1/refined_masks"}
    for s in STAGES:
        if any(p in down for p in PARENTS[s]):
            down.add(s)
    assert ran <= down


def test_editing_inbetween_motion_keeps_masks_and_templates(home, small_shot, tmp_path):
    run_shot(small_shot, tmp_path / "out")
    data = json.loads((small_shot / "shot.json").read_text())
    middle = data["poses"][len(data["poses"]) // 2]
    middle["joints"] = [[x + 1.0, y, z] for x, y, z in middle["joints"]]
    (small_shot / "shot.json").write_text(json.dumps(data))
    ran = executed(run_shot(small_shot, tmp_path / "out"))
    assert not {s for s in ran if s.split("/")[-1] in ("masks", "refined_masks", "template", "textured_template")}
    assert {"seg0/key0/deformed_frames", "seg0/key1/deformed_frames"} <= ran


def test_killed_run_then_rerun_matches_uninterrupted(home, small_shot, tmp_path):
    reference = tmp_path / "ref_home"
    env = {**os.environ, "INBETWEEN_HOME": str(reference), "DAGSTER_HOME": str(reference / "dagster")}
    subprocess.run([sys.executable, "-m", "assets.cli", "run", str(small_shot), "--out", str(tmp_path / "ref")],
                   env=env, check=True, capture_output=True)
    # interrupted: kill once the deformation of key0 has been stored
    env2 = {**os.environ, "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster")}
    proc = subprocess.Popen([sys.executable, "-m", "assets.cli", "run", str(small_shot), "--out", str(tmp_path / "killed")],
                            env=env2, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    marker = home / "storage" / "arm_cross" / "seg0" / "key0" / "deformed_frames" / "meta.json"
    deadline = time.time() + 300
    while not marker.exists() and proc.poll() is None and time.time() < deadline:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    report = run_shot(small_shot, tmp_path / "resumed")
    assert report["stages"]["key0/masks"]["cached"]  # stored before the kill: reused, not recomputed
    np.testing.assert_array_equal(frames_of(tmp_path / "resumed"), frames_of(tmp_path / "ref"))


def test_bad_shot_one_line_error_and_batch_leaves_others_untouched(home, small_shot, tmp_path, capsys):
    root = small_shot.parent
    bad = root / "bad_shot"
    bad.mkdir()
    good_json = json.loads((small_shot / "shot.json").read_text())
    good_json["keyframes"] = ["key0.png", "../arm_cross/key1.png"]
    (bad / "shot.json").write_text(json.dumps(good_json))
    (bad / "key0.png").write_bytes((small_shot / "key0.png").read_bytes())
    assert main(["run", str(bad), "--out", str(tmp_path / "bad_out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "shot.json" in err and "keyframes[1]" in err and "escapes" in err
    assert not (tmp_path / "bad_out" / "frames").exists()
    # a batch: the good shot's earlier outputs stay byte-identical, the bad one fails alone
    out = tmp_path / "batch"
    run_shot(small_shot, out / "arm_cross")
    before = {p: p.read_bytes() for p in (out / "arm_cross" / "frames").glob("*.png")}
    assert main(["batch", str(root), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "bad_shot" in err and "escapes" in err
    after = {p: p.read_bytes() for p in (out / "arm_cross" / "frames").glob("*.png")}
    assert before == after
