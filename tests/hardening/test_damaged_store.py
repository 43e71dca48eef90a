"""Damaged stage outputs are detected, never trusted, never a crash; a full disk keeps the previous output.

Fast tests on the store itself (resources/store.py); the end-to-end ones (a damaged output recomputed
by a run, a deleted or damaged Dagster home, a full disk in a stage) are in test_damaged_state.py.
"""
from __future__ import annotations

import errno
import json
import subprocess
import uuid

import numpy as np
import pytest

import resources.store as store_module
from ops.types import OutputFrames
from resources.store import Store, content_hash, read_value, stored_hash, stored_provenance, write_value


def _frames(seed: int, side: int = 8) -> OutputFrames:
    rng = np.random.default_rng(seed)
    return OutputFrames(np.linspace(0, 1, 3), np.array([0, 0.5, 1.0]), rng.random((3, side, side, 4), dtype=np.float32),
                        "optimal")


def _damage(path, kind: str) -> None:
    if kind == "npz truncated":
        f = path / "arrays.npz"
        f.write_bytes(f.read_bytes()[:-10])
    elif kind == "npz deleted":
        (path / "arrays.npz").unlink()
    elif kind == "image truncated":
        f = path / "frames.0001.exr"
        f.write_bytes(f.read_bytes()[:100])
    elif kind == "image deleted":
        (path / "frames.0002.exr").unlink()
    elif kind == "meta deleted":
        (path / "meta.json").unlink()
    elif kind == "meta truncated":
        f = path / "meta.json"
        f.write_bytes(f.read_bytes()[:20])
    elif kind == "meta a list":
        (path / "meta.json").write_text("[]")
    elif kind == "meta with bad sizes":
        meta = json.loads((path / "meta.json").read_text())
        meta["__files__"] = "arrays.npz"
        (path / "meta.json").write_text(json.dumps(meta))
    elif kind == "meta not UTF-8":
        (path / "meta.json").write_bytes(b"\xff\xfe{")
    elif kind == "directory deleted":
        import shutil

        shutil.rmtree(path)
    elif kind == "a file instead of the directory":
        import shutil

        shutil.rmtree(path)
        path.write_text("x")


DAMAGE = ["npz truncated", "npz deleted", "image truncated", "image deleted", "meta deleted", "meta truncated",
          "meta a list", "meta with bad sizes", "meta not UTF-8", "directory deleted", "a file instead of the directory"]


@pytest.mark.parametrize("kind", DAMAGE)
def test_damaged_output_reads_as_missing_and_is_rewritten(tmp_path, kind):
    st = Store(tmp_path)
    st.write("seg0/rife_matrix", "shot", _frames(0), provenance={"parents": {}})
    path = st.path("seg0/rife_matrix", "shot")
    _damage(path, kind)
    assert st.hash("seg0/rife_matrix", "shot") is None  # never trusted
    assert stored_provenance(path) == (None, None)
    fresh = _frames(1)
    assert st.write("seg0/rife_matrix", "shot", fresh) == content_hash(fresh)  # and rewritten in its place
    np.testing.assert_array_equal(st.read("seg0/rife_matrix", "shot").frames, fresh.frames)


class _DiskFull:
    """np.savez that writes part of the archive, then fails as a full disk does."""

    def __init__(self):
        self.calls = 0

    def __call__(self, f, **arrays):
        self.calls += 1
        f.write(b"PK\x03\x04" + b"\x00" * 1000)
        raise OSError(errno.ENOSPC, "No space left on device")


def test_full_disk_during_a_write_keeps_the_previous_output(tmp_path, monkeypatch):
    path = tmp_path / "stage"
    old = _frames(0)
    write_value(path, old, provenance={"parents": {"a": "1"}})
    with monkeypatch.context() as m, pytest.raises(OSError) as e:
        m.setattr(store_module.np, "savez", _DiskFull())
        write_value(path, _frames(1), provenance={"parents": {"a": "2"}})
    assert e.value.errno == errno.ENOSPC
    assert stored_hash(path) == content_hash(old)
    assert stored_provenance(path)[1] == {"parents": {"a": "1"}}
    np.testing.assert_array_equal(read_value(path).frames, old.frames)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stage"]  # no temporary left behind


@pytest.fixture
def small_tmpfs(tmp_path):
    """A 512 kB tmpfs (needs the right to mount: skipped where it is missing, the patched test covers it)."""
    mnt = tmp_path / f"tmpfs-{uuid.uuid4().hex[:6]}"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(mnt)], capture_output=True).returncode:
        pytest.skip("cannot mount a tmpfs here (not root, or no CAP_SYS_ADMIN)")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)


def test_full_tmpfs_keeps_the_previous_output(small_tmpfs):
    path = small_tmpfs / "stage"
    old = _frames(0, side=16)  # about 12 kB of EXR
    write_value(path, old)
    big = _frames(1, side=256)  # about 3 MB: cannot fit
    with pytest.raises(OSError) as e:
        write_value(path, big)
    assert e.value.errno == errno.ENOSPC
    assert stored_hash(path) == content_hash(old)
    np.testing.assert_array_equal(read_value(path).frames, old.frames)
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ["stage"]
