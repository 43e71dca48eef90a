"""Reading .npz files while other threads parse (ops/shotio/npz.py)."""
import threading

import numpy as np
import pytest

import ops.shotio.npz as npz


@pytest.fixture
def saved(tmp_path):
    arrays = {"a": np.arange(6.0).reshape(2, 3), "b": np.array([1, 2, 3], np.int64)}
    path = tmp_path / "x.npz"
    np.savez(path, **arrays)
    return path, arrays


def test_every_array_comes_back(saved):
    path, arrays = saved
    got = npz.read_npz(path)
    assert got.keys() == arrays.keys()
    for k in arrays:
        np.testing.assert_array_equal(got[k], arrays[k])
        assert got[k].dtype == arrays[k].dtype


def test_a_read_another_threads_parsing_broke_is_read_again_and_other_errors_are_not(saved, monkeypatch):
    path, arrays = saved
    real, calls = np.load, []

    def racing(*args, **kwargs):  # the first read meets CPython 3.11's shared AST state mid-parse
        calls.append(1)
        if len(calls) == 1:
            raise SystemError("AST constructor recursion depth mismatch (before=48, after=45)")
        return real(*args, **kwargs)

    monkeypatch.setattr(npz.np, "load", racing)
    np.testing.assert_array_equal(npz.read_npz(path)["a"], arrays["a"])
    assert len(calls) == 2

    def always(*args, **kwargs):
        raise SystemError("AST constructor recursion depth mismatch (before=1, after=0)")

    monkeypatch.setattr(npz.np, "load", always)
    with pytest.raises(SystemError):  # a race that does not end is not hidden
        npz.read_npz(path)

    def other(*args, **kwargs):
        raise SystemError("something else")

    monkeypatch.setattr(npz.np, "load", other)
    with pytest.raises(SystemError, match="something else"):
        npz.read_npz(path)


def test_reads_from_many_threads_agree(saved):
    path, arrays = saved
    results, errors = [], []

    def work():
        try:
            for _ in range(50):
                results.append(npz.read_npz(path)["a"])
        except Exception as e:  # noqa: BLE001 (reported below)
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(results) == 300
    assert all(np.array_equal(r, arrays["a"]) for r in results)
