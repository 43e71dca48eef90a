"""editor/stage_warnings.py: each stored warning on the keyframe whose lane (or side of a segment) made it."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from editor.stage_warnings import stage_warnings
from ops.warning_subject import about
from resources.store import Store


@dataclass
class _Output:
    value: np.ndarray


def test_a_sides_warning_goes_to_its_key_and_a_blending_stages_to_none(tmp_path):
    store = Store(tmp_path)
    torn = about("bone", "key1's lane draws 59% of the character from stretched triangles", name="knee-foot",
                 at=(144.4, 188.9), fix="click the T-junctions")
    for name, texts in (("key0/masks", ["mask repaired"]), ("seg0/key1/deformed_frames", [torn]),
                        ("seg0/optimal_path", ["an abrupt step"])):
        store.write(name, "shot", _Output(np.zeros(1)), provenance={"warnings": texts})
    got = {w["stage"]: w for w in stage_warnings(store, "shot")}
    assert got["key0/masks"]["k"] == 0 and got["seg0/optimal_path"]["k"] is None
    side = got["seg0/key1/deformed_frames"]
    assert side["k"] == 1 and side["kind"] == "bone" and side["names"] == ["knee-foot"]
    assert side["at"] == [144.4, 188.9] and side["fix"] == "click the T-junctions"
