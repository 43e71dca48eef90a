"""Damaged state end to end: damaged outputs recomputed, a deleted or damaged Dagster home, a full disk in a stage."""
from __future__ import annotations

import errno
import json
import shutil

import pytest

import resources.store as store_module
from assets.cli import main
from assets.graph import shot_graph
from assets.run import StageFailed, run_shot, status

from .conftest import cli
from .test_damaged_store import _DiskFull

pytestmark = pytest.mark.slow


def test_truncated_and_deleted_outputs_are_recomputed(warm, tmp_path):
    before = json.loads((warm.home / "storage" / warm.partition / "inbetween_frames" / "meta.json").read_text())["hash"]
    npz = warm.home / "storage" / warm.partition / "key1" / "template" / "arrays.npz"
    npz.write_bytes(npz.read_bytes()[: npz.stat().st_size // 2])
    shutil.rmtree(warm.home / "storage" / warm.partition / "seg0" / "quality_metrics")
    states = {n: s.state for n, s in status(warm.shot).statuses.items()}
    assert states["key1/template"] == states["seg0/quality_metrics"] == "missing"
    assert states["key0/template"] == "fresh"
    report = run_shot(warm.shot, tmp_path / "out")
    ran = {n for n, s in report["stages"].items() if not s["cached"]}
    assert ran == {"key1/template", "seg0/quality_metrics"}  # recomputed; everything else found its inputs unchanged
    assert report["frames_version"] == before


def test_deleted_dagster_home_starts_over_in_the_same_process(warm, tmp_path):
    warm.forget_dagster_record()
    first = run_shot(warm.shot, tmp_path / "a")  # Dagster started in this process, its instance cached
    shutil.rmtree(warm.home / "dagster")
    second = run_shot(warm.shot, tmp_path / "b")  # a new instance, every stage re-recorded, none recomputed
    assert all(s["cached"] for s in second["stages"].values())
    assert second["frames_version"] == first["frames_version"]
    assert (warm.home / "dagster" / "inbetween_instance_id").is_file()
    assert list((warm.home / "dagster").rglob("*.db"))  # the new instance holds the new runs
    third = run_shot(warm.shot, tmp_path / "c")  # and knows it: no Dagster needed any more
    assert not any(s["executed"] for s in third["stages"].values())


def test_deleted_dagster_home_from_the_cli(warm, tmp_path):
    shutil.rmtree(warm.home / "dagster")
    done = cli(warm.home, "run", str(warm.shot), "--out", str(tmp_path / "out"))
    assert done.returncode == 0 and f"{len(shot_graph(2).stages)} cached" in done.stderr, done.stderr


def test_damaged_dagster_home_is_one_line_with_its_fix(warm, tmp_path):
    for db in (warm.home / "dagster").rglob("runs.db"):
        db.write_bytes(b"this is not a database" * 100)
    warm.forget_dagster_record()
    done = cli(warm.home, "run", str(warm.shot), "--out", str(tmp_path / "out"))
    assert done.returncode == 1 and "Traceback" not in done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "cannot be opened" in errors[0] and "fix: remove" in errors[0], done.stderr


def test_full_disk_in_a_stage_keeps_the_outputs_and_says_so(warm, tmp_path, monkeypatch, capsys):
    stage = warm.home / "storage" / warm.partition / "seg0" / "optimal_path"
    stage_meta = (stage / "meta.json").read_bytes()
    (stage / "meta.json").write_text("{}")  # damaged: optimal_path must be written again
    with monkeypatch.context() as m:  # (not monkeypatch.undo(): that would also undo `warm`'s environment)
        m.setattr(store_module.np, "savez", _DiskFull())
        assert main(["run", str(warm.shot), "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    line = [x for x in err.splitlines() if x.startswith("error:")]
    assert len(line) == 1 and "seg0/optimal_path" in line[0] and "No space left on device" in line[0]
    assert "free disk space" in line[0]
    assert not [p for p in stage.parent.iterdir() if p.name.startswith((".tmp-", ".old-"))]
    other = warm.home / "storage" / warm.partition / "seg0" / "quality_metrics" / "meta.json"
    assert json.loads(other.read_text())["hash"]  # the outputs before it are untouched
    assert main(["run", str(warm.shot), "--out", str(tmp_path / "out")]) == 0  # space again: it goes on
    assert json.loads((stage / "meta.json").read_text())["hash"] == json.loads(stage_meta)["hash"]
    assert len(list((tmp_path / "out" / "frames").glob("*.png"))) == 3
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert {n for n, s in report["stages"].items() if s["executed"]} == {"seg0/optimal_path", "seg0/frames", "inbetween_frames"}


def test_enospc_is_named_by_the_cli_for_any_command(tmp_path, monkeypatch, capsys):
    """Outside a stage (writing the frames, the masks), a full disk is the same one line."""
    import assets.cli as cli_module

    def full(args):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "out" / "frames" / "0000.png"))

    monkeypatch.setitem(cli_module.COMMANDS, "masks", full)
    monkeypatch.setenv("INBETWEEN_HOME", str(tmp_path / "home"))
    assert main(["masks", str(tmp_path), "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No space left on device" in err[0] and "free disk space" in err[0]
    assert "full trace: " in err[0]


def test_a_full_sqlite_database_reads_as_a_full_disk():
    """SQLite says a full disk its own way (the Dagster event log, a stage's own database): same fix, one line."""
    cause = "OperationalError: (sqlite3.OperationalError) database or disk is full\n(Background on this error ...)"
    line = str(StageFailed("arm_cross", "key1/template", cause, None))
    assert "\n" not in line and "database or disk is full" in line and "free disk space" in line
    other = str(StageFailed("arm_cross", "key1/template", "ValueError: no handles", None))
    assert "free disk space" not in other


def test_an_interrupted_run_says_so_and_goes_on_when_rerun(warm, tmp_path, monkeypatch, capsys):
    """Ctrl-C or SIGTERM (which Dagster turns into an interruption) inside a stage: the one line says the run was
    interrupted and a rerun goes on, not the stage's input advice; the stages stored before it are kept."""
    import assets.blending as blending

    shutil.rmtree(warm.home / "storage" / warm.partition / "seg0" / "quality_metrics")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    with monkeypatch.context() as m:
        m.setattr(blending, "interpolation_quality", interrupted)
        assert main(["run", str(warm.shot), "--out", str(tmp_path / "out")]) == 130
    lines = [x for x in capsys.readouterr().err.splitlines() if x.startswith("error:")]
    assert len(lines) == 1 and "quality_metrics: interrupted" in lines[0] and "fix: rerun" in lines[0], lines
    assert "check " not in lines[0]  # no stage's advice about the shot's input
    assert main(["run", str(warm.shot), "--out", str(tmp_path / "out")]) == 0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert {n for n, s in report["stages"].items() if not s["cached"]} == {"seg0/quality_metrics"}
