"""Stage storage: lossless round trips, content hashes, atomic writes."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from ops.types import BlendPath, BlendPaths, OutputFrames, RefinedMasks
from resources.store import Store, content_hash, read_value, stored_hash, write_value


def _refined() -> RefinedMasks:
    fg = np.zeros((6, 7), bool)
    fg[1:5, 1:6] = True
    return RefinedMasks(fg, [fg & (np.arange(7) > 3)], [np.array([2, 3])], [np.random.rand(5, 2)], [np.array([0, 2])],
                        [np.random.rand(9, 2), np.random.rand(4, 2)], np.random.rand(1, 2),
                        fg.astype(np.float32) * 0.5, np.random.rand(6, 7, 3).astype(np.float32),
                        np.random.rand(6, 7, 3).astype(np.float32), ["snapped a joint"])


def test_round_trips_are_exact_and_hash_stable(tmp_path):
    rng = np.random.default_rng(0)
    bp = BlendPath(np.array([0, 3, 8]), 1.5, np.array([0.5, 1.0]), np.array([False, True]))
    values = [
        _refined(),
        BlendPaths(np.linspace(0, 1, 3), np.linspace(0, 1, 9), bp, bp),
        OutputFrames(np.linspace(0, 1, 3), np.array([0, 0.5, 1.0]), rng.random((3, 5, 4, 4), dtype=np.float32), "optimal"),
        pd.DataFrame({"t": [0.0, 1.0], "alpha": [0.0, 1.0], "q": [0.1, 0.2]}),
    ]
    for i, v in enumerate(values):
        path = tmp_path / f"v{i}"
        digest = write_value(path, v)
        back = read_value(path)
        assert content_hash(back) == digest == stored_hash(path)
        if isinstance(v, pd.DataFrame):
            pd.testing.assert_frame_equal(back, v)
    np.testing.assert_array_equal(read_value(tmp_path / "v2").frames, values[2].frames)  # EXR float is lossless
    assert read_value(tmp_path / "v0").warnings == ["snapped a joint"]


def test_rewrite_replaces_atomically_and_leaves_no_temporaries(tmp_path):
    path = tmp_path / "stage"
    write_value(path, _refined())
    second = _refined()
    write_value(path, second)
    assert stored_hash(path) == content_hash(second)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stage"]


def test_missing_or_partial_output_is_not_trusted(tmp_path):
    path = tmp_path / "stage"
    assert stored_hash(path) is None
    path.mkdir()
    (path / "arrays.npz").write_bytes(b"half")  # a killed writer before meta.json: never trusted
    assert stored_hash(path) is None


def test_an_output_written_ahead_is_renamed_into_place_by_its_write(tmp_path):
    """Store.stage (the work-ahead's thread) writes beside the output's place; write() of that very output only
    renames it there; a different output, or a different record, is written afresh; discard() leaves nothing."""
    store = Store(tmp_path)
    value, record = _refined(), {"parents": {"a": "1"}}
    digest = content_hash(value)
    store.stage("key0/refined_masks", "shot", value, digest, record)
    parent = tmp_path / "shot" / "key0"
    assert [p.name.startswith(".tmp-") for p in parent.iterdir()] == [True]  # not in place: nobody reads it
    assert store.hash("key0/refined_masks", "shot") is None
    assert store.write("key0/refined_masks", "shot", value, digest, json.loads(json.dumps(record))) == digest
    assert sorted(p.name for p in parent.iterdir()) == ["refined_masks"]
    assert store.provenance("key0/refined_masks", "shot") == (digest, record)
    assert content_hash(store.read("key0/refined_masks", "shot")) == digest

    other = _refined()
    store.stage("key0/refined_masks", "shot", other, content_hash(other), {"parents": {"a": "2"}})
    store.write("key0/refined_masks", "shot", other, content_hash(other), {"parents": {"a": "3"}})
    assert store.provenance("key0/refined_masks", "shot") == (content_hash(other), {"parents": {"a": "3"}})
    assert sorted(p.name for p in parent.iterdir()) == ["refined_masks"]

    store.stage("key0/masks", "shot", value, digest, record)
    store.discard("key0/masks", "shot")
    assert sorted(p.name for p in parent.iterdir()) == ["refined_masks"]


def test_hash_while_pandas_is_half_imported(monkeypatch):
    """An idle worker imports pandas on its own thread; meanwhile sys.modules holds the half-initialized module,
    with no DataFrame yet. Hashing a stage's value then must not touch it (two_poses crashed in
    seg0/key1/textured_template with "partially initialized module 'pandas' has no attribute 'DataFrame'")."""
    import sys
    import types

    expected = content_hash(_refined_fixed())
    monkeypatch.setitem(sys.modules, "pandas", types.ModuleType("pandas"))
    assert content_hash(_refined_fixed()) == expected
    monkeypatch.undo()
    assert content_hash(pd.DataFrame({"q": [0.1]})) == content_hash(pd.DataFrame({"q": [0.1]}))


def _refined_fixed() -> RefinedMasks:
    """_refined with fixed numbers, so two calls hash alike."""
    np.random.seed(3)
    return _refined()


def test_an_output_written_before_a_field_existed_reads_with_its_default(tmp_path):
    """A home from an older version: an output stored before a field with a default existed still reads (planning,
    the editor and the UI read stored outputs before a stale stage runs again), with the field's default."""
    path = tmp_path / "refined"
    write_value(path, _refined())
    meta = json.loads((path / "meta.json").read_text())
    del meta["warnings"]  # (RefinedMasks.warnings has a default)
    (path / "meta.json").write_text(json.dumps(meta))
    old = read_value(path)
    assert old.warnings == [] and old.foreground.sum() == _refined().foreground.sum()
    del meta["junctions"]  # a field without a default is still required: the output is damaged
    (path / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(KeyError):
        read_value(path)


def test_an_image_matrix_stores_and_hashes_only_its_filled_cells(tmp_path):
    """The cells a path did not need are zero: stored as their places only, read back exactly (a -0.0 or a NaN
    is not zero), and the hash tells every cell's value and place apart."""
    from ops.types import ImageMatrix
    from resources.store import SLAB_MIN_BYTES, filled_slabs

    rng = np.random.default_rng(1)
    t, a, h, w = 3, 5, 80, 64
    computed = np.zeros((t, a), bool)
    computed[:, [0, 2, 4]] = True
    computed[1, 1] = True
    frames = np.zeros((t, a, h, w, 4), np.float32)
    frames[computed] = rng.random((int(computed.sum()), h, w, 4), dtype=np.float32)
    frames[0, 1, 5, 5, 0] = -0.0  # a negative zero alone: a filled cell
    frames[2, 3, 7, 7, 1] = np.nan
    assert frames.nbytes >= SLAB_MIN_BYTES
    m = ImageMatrix(np.linspace(0, 1, t), np.linspace(0, 1, a), frames, rng.random((t, h, w, 4), dtype=np.float32),
                    computed)
    expected = computed.copy()
    expected[0, 1] = expected[2, 3] = True
    np.testing.assert_array_equal(filled_slabs(frames), expected)
    digest = write_value(tmp_path / "m", m)
    back = read_value(tmp_path / "m")
    assert np.array_equal(back.frames.view(np.uint32), frames.view(np.uint32))  # bit for bit
    assert content_hash(back) == digest
    size = (tmp_path / "m" / "arrays.npz").stat().st_size
    assert size < frames.nbytes * 12 / 15 + m.flows.nbytes + 10_000  # 12 of 15 cells written
    moved = frames.copy()
    moved[[0, 1]] = frames[[1, 0]]  # the same cells in other places
    assert content_hash(ImageMatrix(m.times, m.alphas, moved, m.flows, computed)) != digest
    dense = frames.copy()
    dense[dense == 0] = 1e-30  # no zero cell left: stored and hashed whole
    assert filled_slabs(dense) is None
