"""`inbetween junctions`: proposals only for keys without clicks, never used unless written, a click always wins."""
from __future__ import annotations

import json

import numpy as np
import pytest

from assets.cli import main
from assets.run.junctions import accept_junctions, propose_junctions

from .conftest import SAMPLES, scaled_copy

pytestmark = pytest.mark.slow


def test_proposals_go_to_keys_without_clicks_and_only_when_written(home, tmp_path, capsys):
    shot = scaled_copy(SAMPLES / "arm_cross", tmp_path / "shots" / "arm_cross", 0.5)
    data = json.loads((shot / "shot.json").read_text())
    clicks = data["t_junctions"][1]
    data["t_junctions"][1] = []  # key 1 arrives without clicks; key 0 gets one of its own
    data["t_junctions"][0] = [[60.0, 80.0]]
    (shot / "shot.json").write_text(json.dumps(data))
    props = propose_junctions(shot)
    assert set(props) == {1}  # key 0 has a click: nothing proposed there
    p = props[1]
    assert len(p.points) and np.all(np.diff(p.scores) <= 0) and ((p.scores >= 0) & (p.scores <= 1)).all()
    truth = np.asarray(clicks)  # the generator's exact junctions: at least one is proposed within 5 px
    assert (np.linalg.norm(p.points[:, None] - truth[None], axis=2).min(axis=0) <= 5).any()
    assert json.loads((shot / "shot.json").read_text())["t_junctions"][1] == []  # proposing writes nothing
    n = accept_junctions(shot, props, min_score=0.0)
    after = json.loads((shot / "shot.json").read_text())
    assert n == len(p.points) == len(after["t_junctions"][1]) and after["t_junctions"][0] == [[60.0, 80.0]]
    assert (shot / "shot.json.bak").is_file()
    assert main(["junctions", str(shot)]) == 0  # every key has clicks now
    assert "nothing to propose" in capsys.readouterr().out
    # written from the command line, the proposals become clicks: it says so, and where to check them
    data["t_junctions"][1] = []
    (shot / "shot.json").write_text(json.dumps(data))
    assert main(["junctions", str(shot), "--write", "--min-score", "0"]) == 0
    out = capsys.readouterr().out
    assert "wrote" in out and "they count as clicks now" in out and "refined_masks" in out
