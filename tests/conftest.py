"""Suite-wide guards."""

from __future__ import annotations

import os

import pytest

import ops  # noqa: F401  (pins the numerical libraries' SIMD level before any test module loads NumPy: ops/simd.py)


@pytest.fixture(autouse=True)
def _no_exec_in_the_test_process(monkeypatch):
    """`inbetween ui` and `inbetween edit` replace their process (os.execv): called in-process by a test, that would
    run a server in pytest's place until its timeout's SIGALRM kills the whole suite. Tests that mean it patch these."""
    def refuse(*args, **kwargs):
        raise AssertionError(f"a test called os.exec* in the pytest process: {args[:2]}")

    for name in ("execv", "execve", "execvp", "execvpe", "execl", "execlp"):
        monkeypatch.setattr(os, name, refuse)
