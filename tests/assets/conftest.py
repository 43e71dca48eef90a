"""Fixtures for end-to-end tests: a private instance home and small copies of sample shots."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from ops.shotio.image_io import read_image, write_image

SAMPLES = Path(__file__).resolve().parents[2] / "data_samples"


def scaled_copy(src: Path, dst: Path, factor: float) -> Path:
    """Copy a shot, resizing every image and scaling every coordinate by `factor` (keeps tests fast)."""
    dst.mkdir(parents=True, exist_ok=True)
    data = json.loads((src / "shot.json").read_text())
    for img_path in src.rglob("*.png"):
        rel = img_path.relative_to(src)
        img = read_image(img_path)
        h, w = img.shape[:2]
        small = cv2.resize(img, (round(w * factor), round(h * factor)), interpolation=cv2.INTER_AREA)
        write_image(dst / rel, small.reshape(small.shape[0], small.shape[1], -1))
    for pose in data["poses"]:
        pose["joints"] = [[x * factor, y * factor, z] for x, y, z in pose["joints"]]
    data["t_junctions"] = [[[x * factor, y * factor] for x, y in pts] for pts in data["t_junctions"]]
    (dst / "shot.json").write_text(json.dumps(data, indent=1))
    return dst


@pytest.fixture
def home(tmp_path, monkeypatch):
    """A fresh INBETWEEN_HOME / DAGSTER_HOME for one test."""
    h = tmp_path / "home"
    monkeypatch.setenv("INBETWEEN_HOME", str(h))
    monkeypatch.setenv("DAGSTER_HOME", str(h / "dagster"))
    monkeypatch.setenv("INBETWEEN_SHOTS", str(tmp_path / "shots"))
    return h


@pytest.fixture
def small_shot(tmp_path):
    """arm_cross at half size: occlusion in key1 with T-junctions."""
    return scaled_copy(SAMPLES / "arm_cross", tmp_path / "shots" / "arm_cross", 0.5)


def frames_of(out: Path) -> np.ndarray:
    return np.stack([read_image(p) for p in sorted((out / "frames").glob("*.png"))])


def copy_shot(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst
