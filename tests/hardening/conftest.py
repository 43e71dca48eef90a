"""Fixtures of the hardening tests: one tiny shot run once per session, cloned warm into each test.

A full run of even a tiny shot costs a minute or more on two shared cores (RIFE), so the session runs
it once; `warm` gives each test its own copy of the shot and of INBETWEEN_HOME (storage, Dagster
instance, registry) in which every stage is already fresh, and points the environment at them.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.assets.conftest import SAMPLES, scaled_copy

ROOT = Path(__file__).resolve().parents[2]
SHOT = "tiny"


def make_tiny(dst: Path) -> Path:
    """two_poses at 96 px with 3 frames (t = 0, 0.5, 1) and the matching 3 ground-truth frames."""
    shot = scaled_copy(SAMPLES / "two_poses", dst, 0.375)
    data = json.loads((shot / "shot.json").read_text())
    data["frames"] = 3
    (shot / "shot.json").write_text(json.dumps(data, indent=1))
    gt = shot / data["ground_truth"]
    keep = {"0000.png": "0000.png", "0004.png": "0001.png", "0008.png": "0002.png"}
    for f in sorted(gt.iterdir()):
        if f.name not in keep:
            f.unlink()
    for old, new in keep.items():
        (gt / old).rename(gt / f".{new}")
    for new in keep.values():
        (gt / f".{new}").rename(gt / new)
    return shot


def env_for(home: Path) -> dict:
    """The environment of a CLI subprocess that uses `home` and this worktree's code."""
    env = {**os.environ, "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster"), "PYTHONPATH": str(ROOT)}
    env.pop("INBETWEEN_PROGRESS", None)
    return env


def cli(home: Path, *args: str, timeout: float = 900, **kwargs) -> subprocess.CompletedProcess:
    """Run `python -m assets.cli ARGS` against `home`; stdout and stderr captured as text."""
    return subprocess.run([sys.executable, "-m", "assets.cli", *args], env=env_for(home), cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout, **kwargs)


@pytest.fixture(scope="session")
def warm_source(tmp_path_factory):
    """(shot dir, home) after one full run and one evaluation of the tiny shot, in a session directory."""
    base = tmp_path_factory.mktemp("warm")
    shot = make_tiny(base / "shots" / SHOT)
    home = base / "home"
    done = cli(home, "eval", str(shot.parent), "--out", str(base / "eval"), timeout=1800)
    assert done.returncode == 0, done.stderr
    return shot, home


@dataclass
class Warm:
    shot: Path  # this test's copy of the tiny shot
    home: Path  # this test's INBETWEEN_HOME, every stage of the shot fresh
    partition: str

    def forget_dagster_record(self) -> None:
        """Make the next run start Dagster (to re-record the stages), though every stage stays fresh."""
        (self.home / "storage" / self.partition / "dagster.json").unlink(missing_ok=True)


def clone_warm(src_shot: Path, src_home: Path, dst: Path) -> Warm:
    """Copy the warm shot and home under dst, the registry pointing the shot's partition at the copy."""
    shot = dst / "shots" / SHOT
    shutil.copytree(src_shot, shot)
    home = dst / "home"
    shutil.copytree(src_home, home, ignore=shutil.ignore_patterns("locks", "logs"))
    registry = home / "shots.json"
    reg = json.loads(registry.read_text())
    partition = next(k for k, v in reg.items() if v == str(src_shot.resolve()))
    reg[partition] = str(shot.resolve())
    registry.write_text(json.dumps(reg))
    return Warm(shot, home, partition)


@pytest.fixture
def warm(warm_source, tmp_path, monkeypatch) -> Warm:
    """A copy of the warm shot and home for this test; INBETWEEN_HOME and DAGSTER_HOME point at it."""
    w = clone_warm(*warm_source, tmp_path)
    monkeypatch.setenv("INBETWEEN_HOME", str(w.home))
    monkeypatch.setenv("DAGSTER_HOME", str(w.home / "dagster"))
    monkeypatch.setenv("INBETWEEN_SHOTS", str(w.shot.parent))
    monkeypatch.delenv("INBETWEEN_PROGRESS", raising=False)
    return w
