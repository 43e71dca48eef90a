"""Skeleton templates: AnimatedDrawings' humanoid exactly, valid trees, files validated like shot.json."""
import json

import numpy as np
import pytest

from ops.errors import ShotError
from ops.shotio.load import parse_skeleton
from ops.skeleton.templates import HUMANOID, TEMPLATES, load_template

AD_PARENTS = {"root": None, "hip": "root", "torso": "hip", "neck": "torso", "right_shoulder": "torso",
              "right_elbow": "right_shoulder", "right_hand": "right_elbow", "left_shoulder": "torso",
              "left_elbow": "left_shoulder", "left_hand": "left_elbow", "right_hip": "root",
              "right_knee": "right_hip", "right_foot": "right_knee", "left_hip": "root", "left_knee": "left_hip",
              "left_foot": "left_knee"}


def test_humanoid_is_animated_drawings_skeleton():
    got = {j: (None if p < 0 else HUMANOID.joints[p]) for j, p in zip(HUMANOID.joints, HUMANOID.parents)}
    assert got == AD_PARENTS


@pytest.mark.parametrize("name", sorted(TEMPLATES))
def test_builtin_templates_are_valid_skeletons_inside_the_unit_box(name, tmp_path):
    t = TEMPLATES[name]
    parse_skeleton({"skeleton": {"joints": list(t.joints), "parents": list(t.parents)}}, tmp_path / "x.json")
    assert t.positions.shape == (len(t.joints), 2)
    assert (t.positions >= 0).all() and (t.positions <= 1).all()
    assert all(p < i for i, p in enumerate(t.parents))  # parents before children


def test_file_template_round_trips_and_spreads_missing_positions(tmp_path):
    f = tmp_path / "snake.json"
    f.write_text(json.dumps({"joints": ["a", "b", "c", "d"], "parents": [-1, 0, 0, 1]}))
    t = load_template(f)
    assert t.joints == ("a", "b", "c", "d") and t.parents == (-1, 0, 0, 1)
    assert len({tuple(p) for p in t.positions.round(6)}) == 4  # every joint at its own spot
    f.write_text(json.dumps(t.to_json()))
    assert np.allclose(load_template(f).positions, t.positions, atol=1e-4)


@pytest.mark.parametrize("data, field", [
    ({"joints": ["a", "a"], "parents": [-1, 0]}, "skeleton.joints"),
    ({"joints": ["a", "b"], "parents": [-1, 0], "positions": [[0, 0]]}, "positions"),
    ({"joints": ["a", "b"], "parents": [-1, 0], "positions": [[0, 0], [2, 0]]}, "positions"),
])
def test_bad_skeleton_files_name_the_field(tmp_path, data, field):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(data))
    with pytest.raises(ShotError, match=field):
        load_template(f)


def test_unknown_name_is_one_clear_error(tmp_path):
    with pytest.raises(ShotError, match="humanoid, quadruped"):
        load_template(tmp_path / "nope")
