"""Fixtures of the geometry tests."""
import pytest

from ops.geometry import handles


@pytest.fixture
def midpoint_handles(monkeypatch):
    """Handles at the joints and bone midpoints only: the scenes below name handles by index in that layout
    (joints, then one midpoint per bone). The machinery under test does not depend on how many handles a bone has."""
    monkeypatch.setattr(handles, "BONE_FRACTIONS", (0.5,))
