"""The generated occlusion dataset: held-out seeds, balanced classes, deterministic samples, consistent truth."""
from __future__ import annotations

import json
from collections import Counter

import numpy as np
import pytest

from data_samples.generator import occlusion_set as ds


def test_train_and_test_seeds_are_disjoint():
    train = [ds.sample_seed("train", i) for i in (0, 1, 12345, ds.TEST_SEED_BASE - 1)]
    test = [ds.sample_seed("test", i) for i in (0, 1, 12345)]
    assert max(train) < min(test) == ds.TEST_SEED_BASE
    with pytest.raises(ValueError):
        ds.sample_seed("train", ds.TEST_SEED_BASE)  # would reach a test seed
    with pytest.raises(ValueError):
        ds.sample_seed("validation", 0)


def test_test_split_is_balanced():
    """Any 25 consecutive indices hold every class in every style once."""
    combos = Counter((ds.sample_class(i), ds.sample_style(i)) for i in range(25))
    assert len(combos) == 25 and set(ds.CLASSES) == {c for c, _ in combos}
    assert Counter(ds.sample_class(i) for i in range(60)) == {c: 12 for c in ds.CLASSES}


def test_samples_are_deterministic_and_splits_differ():
    a, b = ds.make_sample("test", 7), ds.make_sample("test", 7)
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.pose, b.pose)
    assert a.pairs == b.pairs and len(a.occlusion) == len(b.occlusion)
    c = ds.make_sample("train", 7)
    assert c.label == a.label and c.style == a.style and not np.array_equal(c.pose, a.pose)


@pytest.mark.parametrize("index", range(10))
def test_sample_ground_truth(index):
    s = ds.make_sample("test", index)
    h, w = s.image.shape[:2]
    assert s.image.dtype == np.uint8 and s.image.shape[2] == 3
    assert ds.MIN_SIZE <= h <= ds.MAX_SIZE and ds.MIN_SIZE <= w <= ds.MAX_SIZE
    assert s.label == ds.CLASSES[index % 5] and s.style == ds.sample_style(index)
    assert s.pose.shape == (len(s.joints), 3) and len(s.parents) == len(s.joints)
    fg = s.foreground >= 0.5
    union = np.zeros((h, w), bool)
    for m, p in zip(s.occlusion, s.pairs):
        assert m.shape == (h, w) and m.sum() >= 12 and not (m & ~fg).any()
        assert p["front_depth"] <= p["back_depth"]
        union |= m
    np.testing.assert_array_equal(union, s.occlusion_union)
    assert 0.02 < fg.mean() < 0.7  # the character fills a good part of the frame
    edges = fg[0].any() or fg[-1].any() or fg[:, 0].any() or fg[:, -1].any()
    assert not edges  # and is not cut by the border
    if s.label != "props":  # the class's own occlusion is there (props: the hinges overlap)
        assert any(not p["adjacent"] and p["pixels"] >= ds.MIN_EVIDENCE_PX for p in s.pairs)


def test_cli_writes_one_folder_per_sample(tmp_path):
    ds.main(["--split", "test", "--n", "2", "--start", "3", "--out", str(tmp_path)])
    folders = sorted(p.name for p in tmp_path.iterdir())
    assert folders == ["test_0000003", "test_0000004"]
    d = tmp_path / folders[0]
    meta = json.loads((d / "meta.json").read_text())
    skel = json.loads((d / "skeleton.json").read_text())
    assert meta["class"] == "round_body" and meta["style"] in ds.STYLE_NAMES and meta["seed"] == ds.TEST_SEED_BASE + 3
    assert len(skel["pose"]) == len(skel["joints"]) == len(skel["parents"])
    assert {m["file"] for m in meta["masks"]} == {p.name for p in d.glob("occ_*.png")} - {"occ_union.png"}
    assert all({"front_part", "back_part", "adjacent"} <= set(m) for m in meta["masks"])
    for f in ("image.png", "fg.png", "occ_union.png"):
        assert (d / f).is_file()
