"""`inbetween status` is transitive and honest: the stages it calls not fresh are exactly those the next run
executes, after an annotation edit, a settings change and a code change (issue 14)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from assets import run as runs
from assets.cli import main
from assets.graph import shot_graph
from assets.run import planning
from ops.settings import Settings

STAGES = shot_graph(2).stages
ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.slow

KEY0_UPSTREAM = ("key0/masks", "key0/refined_masks", "key0/template")


def not_fresh(shot, settings=None) -> set[str]:
    return {n for n, s in runs.status(shot, settings).statuses.items() if s.state != "fresh"}


def executed(report: dict) -> set[str]:
    return {n for n, s in report["stages"].items() if s["executed"]}


def test_status_predicts_exactly_what_run_executes(home, small_shot, tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    runs.run_shot(small_shot, out)
    # the first run in this home planned without the code records; it leaves them cached for the plans below
    assert json.loads((home / "code_records.json").read_text())["records"] == planning.code_records()
    assert not_fresh(small_shot) == set()

    # 1. a key1 T-junction moves by one pixel
    data = json.loads((small_shot / "shot.json").read_text())
    data["t_junctions"][1][0][0] += 1.0
    (small_shot / "shot.json").write_text(json.dumps(data))
    plan = runs.status(small_shot)
    stale = {n for n, s in plan.statuses.items() if s.state != "fresh"}
    key1_down = {"key1/refined_masks", "key1/template", "seg0/key1/textured_template", "seg0/key1/deformed_frames",
                 "seg0/rife_matrix", "seg0/quality_metrics", "seg0/optimal_path", "seg0/frames", "inbetween_frames"}
    assert key1_down <= stale and not stale & set(KEY0_UPSTREAM) and "key1/masks" not in stale
    assert plan.statuses["key1/refined_masks"].causes == ["key1/t_junctions changed"]
    assert "upstream key1/template stale" in plan.statuses["seg0/key1/textured_template"].causes
    # key0's texture reads key1's refined masks (which parts of key0's pockets key1 shows, §5.1)
    assert stale - key1_down <= {"seg0/key0/textured_template", "seg0/key0/deformed_frames"}
    assert main(["status", str(small_shot), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert {n for n, s in printed["stages"].items() if s["state"] != "fresh"} == stale
    assert executed(runs.run_shot(small_shot, out)) == stale
    assert not_fresh(small_shot) == set()

    # 2. a setting: the single-layer ablation reruns the templates and what follows, not the masks
    single = Settings(template_mode="single-layer")
    stale = not_fresh(small_shot, single)
    assert {"key0/template", "key1/template", "inbetween_frames"} <= stale
    assert not stale & {"key0/masks", "key0/refined_masks", "key1/masks", "key1/refined_masks"}
    assert runs.status(small_shot, single).statuses["key0/template"].causes == [
        "setting template_mode changed (optimized -> single-layer)"]
    assert executed(runs.run_shot(small_shot, tmp_path / "single", single)) == stale
    runs.run_shot(small_shot, out)  # back to the default
    # the lanes' registration onto the other key is read by the deformed frames alone: the textures stay fresh
    unregistered = Settings(register_lanes=False)
    plan = runs.status(small_shot, unregistered)
    assert {n for n, s in plan.statuses.items() if s.state != "fresh"} == {
        "seg0/key0/deformed_frames", "seg0/key1/deformed_frames", "seg0/rife_matrix", "seg0/quality_metrics",
        "seg0/optimal_path", "seg0/frames", "inbetween_frames"}
    assert plan.statuses["seg0/key1/deformed_frames"].causes == ["setting register_lanes changed (True -> False)"]

    # 3. a code change in the template's closure (simulated: the recorded file hashes differ from now)
    records = planning.code_records()
    edited = {n: dict(r) for n, r in records.items()}
    for r in edited.values():
        if "ops/geometry/template.py" in r:
            r["ops/geometry/template.py"] = "edited"
    monkeypatch.setattr(planning, "code_records", lambda: edited)
    plan = runs.status(small_shot)
    stale = {n for n, s in plan.statuses.items() if s.state != "fresh"}
    assert plan.statuses["key0/template"].causes == ["code changed: ops/geometry/template.py"]
    assert {"key0/template", "key1/template", "inbetween_frames"} <= stale and "key0/masks" not in stale
    assert stale == set(STAGES) - {"key0/masks", "key0/refined_masks", "key1/masks", "key1/refined_masks"}
    assert executed(runs.run_shot(small_shot, out)) == stale


def test_a_shots_first_plan_in_a_new_home_needs_no_dagster(home, small_shot):
    # nothing stored: every stage runs whatever the code records say, so the plan does not import the definitions
    # (and Dagster with them) before the run's first stage can start
    code = ("import json, sys; from assets.run.planning import plan; p = plan(sys.argv[1]); "
            "print(json.dumps([sorted(p.to_run), 'dagster' in sys.modules]))")
    out = subprocess.run([sys.executable, "-c", code, str(small_shot)], cwd=ROOT, capture_output=True, text=True,
                         check=True)
    to_run, dagster = json.loads(out.stdout.strip().splitlines()[-1])
    assert to_run == sorted(STAGES) and not dagster
    assert not (home / "code_records.json").exists()


def _directly_stale(shot) -> dict[str, list[str]]:
    """Stages stale for a reason of their own (not only upstream), with those reasons."""
    out = {}
    for n, s in runs.status(shot).statuses.items():
        own = [c for c in s.causes if not c.startswith("upstream")]
        if own:
            out[n] = own
    return out


def test_a_resource_change_makes_exactly_its_users_stale(home, small_shot, tmp_path, monkeypatch):
    """Every field of every resource is in the provenance of the stages that use it, and of no other."""
    runs.run_shot(small_shot, tmp_path / "out")
    users = {"rife": {"seg0/rife_matrix", "seg0/frames"},  # the frames: the keys' interpolation where no lane holds
             "inpainter": {"seg0/key0/textured_template", "seg0/key1/textured_template"}}
    changes = [("INBETWEEN_RIFE_BATCH", "4", "rife", "batch"), ("INBETWEEN_RIFE_WEIGHTS", "/elsewhere.pkl", "rife",
                                                                  "weights_path"),
               ("INBETWEEN_DEVICE", "cuda", "rife", "device"), ("INBETWEEN_RIFE_RUNTIME", "torch", "rife", "runtime"),
               ("INBETWEEN_INPAINTER", "ns", "inpainter", "method"),
               ("INBETWEEN_INPAINT_RADIUS", "9", "inpainter", "radius")]
    for var, value, key, field in changes:
        monkeypatch.setenv(var, value)
        direct = _directly_stale(small_shot)
        assert set(direct) == users[key], (var, direct)
        assert all(any(c.startswith(f"resource {key} changed ({field} ") for c in cs) for cs in direct.values())
        monkeypatch.delenv(var)
    assert not_fresh(small_shot) == set()


def test_a_run_observes_only_the_sources_that_changed_and_the_instance_keeps_every_current_version(
        home, small_shot, tmp_path, monkeypatch):
    from dagster._core.definitions.data_version import extract_data_version_from_entry

    from assets.run.session import Session
    from assets.stage import asset_key
    from ops.shotio.load import load_shot
    from ops.shotio.versions import source_versions

    observed: list[set[str]] = []
    observe = Session.observe
    monkeypatch.setattr(Session, "observe", lambda self, partition, sources: (
        observed.append(set(sources)), observe(self, partition, sources))[1])
    runs.run_shot(small_shot, tmp_path / "out")
    data = json.loads((small_shot / "shot.json").read_text())
    data["t_junctions"][1][0][0] += 1.0
    (small_shot / "shot.json").write_text(json.dumps(data))
    runs.run_shot(small_shot, tmp_path / "out")
    shot = load_shot(small_shot)
    current = source_versions(shot)
    assert observed == [set(current), {"key1/t_junctions"}]
    plan = runs.status(small_shot)
    instance = Session.get(Settings()).instance
    for name, version in current.items():  # what the UI compares the stages' inputs with
        record = instance.get_latest_data_version_record(asset_key(name), is_source=True,
                                                         partition_key=plan.partition)
        assert extract_data_version_from_entry(record.event_log_entry).value == version, name
