"""`inbetween masks` writes masks in exactly the form a shot's manual masks accept, and a shot that is given them
back uses them unchanged (issue 8)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from assets import run as runs
from assets.cli import main
from ops.shotio.image_io import read_image

pytestmark = pytest.mark.slow


def test_exported_masks_round_trip_as_manual_masks(home, small_shot, tmp_path, capsys):
    out = tmp_path / "masks"
    assert main(["masks", str(small_shot), "--out", str(out)]) == 0
    printed = capsys.readouterr().out.split()
    names = sorted(p.rsplit("/", 1)[-1] for p in printed)
    assert {"key0_foreground.png", "key1_foreground.png", "key1_occlusion_0.png"} <= set(names)
    fg0 = read_image(out / "key0_foreground.png")
    key = read_image(small_shot / "key0.png")
    assert fg0.shape == key.shape[:2] + (1,) and set(np.unique(np.round(fg0 * 255))) <= {0.0, 255.0}
    partition = runs.register(small_shot)
    refined = [runs.store().read(f"key{k}/refined_masks", partition) for k in (0, 1)]
    # hand them back as manual masks: the masks stage then holds exactly them
    for f in out.iterdir():
        (small_shot / f.name).write_bytes(f.read_bytes())
    data = json.loads((small_shot / "shot.json").read_text())
    occ = [sorted(n for n in names if n.startswith(f"key{k}_occlusion")) for k in (0, 1)]
    data["masks"] = {"foreground": ["key0_foreground.png", "key1_foreground.png"], "occlusion": occ}
    (small_shot / "shot.json").write_text(json.dumps(data))
    runs.run_shot(small_shot, tmp_path / "out")
    for k in (0, 1):
        masks = runs.store().read(f"key{k}/masks", partition)
        assert masks.source == ("manual" if occ[k] else "mixed")
        assert np.array_equal(masks.foreground, refined[k].foreground)
        assert len(masks.occlusion) == len(refined[k].occlusion) or not occ[k]
        if occ[k]:  # the same regions; their back-to-front order is re-derived from their own front bones
            assert sorted(r.tobytes() for r in masks.occlusion) == sorted(r.tobytes() for r in refined[k].occlusion)
