"""A run says when the SIMD pin (ops/simd.py) does not hold in its process."""
from __future__ import annotations

import pytest

from assets.run.execute import run_shot
from ops import simd
from ops.errors import ShotError


def test_run_shot_warns_when_the_pin_does_not_hold(monkeypatch, tmp_path):
    monkeypatch.setattr(simd, "unheld", lambda: "NumPy was imported before the inbetween packages; fix: ...")
    with pytest.warns(RuntimeWarning, match="imported before the inbetween packages"), pytest.raises(ShotError):
        run_shot(tmp_path / "no_shot", tmp_path / "out")  # warned first, then refused as bad input


def test_a_run_in_a_pinned_process_does_not_warn(tmp_path, recwarn):
    with pytest.raises(ShotError):
        run_shot(tmp_path / "no_shot", tmp_path / "out")
    assert not [w for w in recwarn if "inbetween packages" in str(w.message)]
