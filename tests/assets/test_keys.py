"""Shots of any number of keys end to end: a sequence shares each key's lane between its segments, an edit of
one key reruns exactly its lane and the segments beside it, and one drawing is animated along its poses."""
from __future__ import annotations

import json

import numpy as np
import pytest

from assets.graph import shot_graph
from assets.run import run_shot, status
from ops.evaluation.metrics import psnr
from ops.shotio.image_io import read_image, to_rgba

from .conftest import SAMPLES, frames_of, scaled_copy

pytestmark = pytest.mark.slow


def _ran(report: dict) -> set[str]:
    return {n for n, s in report["stages"].items() if not s["cached"]}


def _over_white(rgba: np.ndarray) -> np.ndarray:
    return rgba[..., :3] * rgba[..., 3:] + (1 - rgba[..., 3:])


def test_a_three_key_sequence_shares_its_keys_and_reruns_one_key_alone(home, tmp_path):
    shot = scaled_copy(SAMPLES / "seq_arm_cross", tmp_path / "shots" / "seq", 0.5)
    out = tmp_path / "out"
    first = run_shot(shot, out)
    graph = shot_graph(3)
    assert _ran(first) == set(graph.stages) and len(graph.stages) == 3 * 3 + 2 * 8 + 1
    assert first["frames"] == 17 and first["key_frames"] == [0, 8, 16] and len(first["segments"]) == 2
    frames = frames_of(out)
    for k, f in enumerate((0, 8, 16)):  # every key comes back as its drawing
        key = to_rgba(read_image(shot / f"key{k}.png"))
        assert psnr(_over_white(frames[f]), _over_white(key)) > 40
    # each side's frames read the segment's other key's masks (registered onto its drawing near that key)
    assert "key1/masks" in graph.parents["seg0/key0/deformed_frames"] and \
        "key1/masks" in graph.parents["seg1/key2/deformed_frames"] and \
        "key2/masks" not in graph.parents["seg0/key1/deformed_frames"]
    # the middle key's T-junction edit: its lane and both segments rerun, key 0's and key 2's lanes do not
    data = json.loads((shot / "shot.json").read_text())
    data["t_junctions"][1][0][0] += 1.5
    (shot / "shot.json").write_text(json.dumps(data))
    stale = {n for n, s in status(shot).statuses.items() if s.state != "fresh"}
    assert not {n for n in stale if n.startswith(("key0/", "key2/"))}
    assert {"key1/refined_masks", "key1/template", "seg0/rife_matrix", "seg1/rife_matrix"} <= stale
    second = run_shot(shot, out)
    assert not {n for n in _ran(second) if n.startswith(("key0/", "key2/"))}


def test_one_drawing_is_deformed_along_its_poses_without_rife(home, tmp_path):
    shot = scaled_copy(SAMPLES / "one_arm_swing", tmp_path / "shots" / "one", 1.0)  # at 128 px the forearm is 5 px wide
    out = tmp_path / "out"
    report = run_shot(shot, out)
    assert set(report["stages"]) == set(shot_graph(1).stages) and not any("rife" in n for n in report["stages"])
    frames = frames_of(out)
    assert len(frames) == 13 and report["segments"] == []
    drawing = to_rgba(read_image(shot / "key0.png"))
    assert psnr(_over_white(frames[0]), _over_white(drawing)) >= 40
    gt = [_over_white(to_rgba(read_image(shot / "gt" / f"{i:04d}.png"))) for i in range(1, 13)]
    ours = np.mean([psnr(_over_white(f), g) for f, g in zip(frames[1:], gt)])
    held = np.mean([psnr(_over_white(drawing), g) for g in gt])
    assert ours > held + 1.0  # the arm moves as the motion says, in front of the body
    assert (out / "oca" / f"{report['partition']}.oca").is_file()
