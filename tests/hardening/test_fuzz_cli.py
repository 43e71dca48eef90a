"""Fuzzed shots through the real CLI (a sample; the many cases are in test_fuzz_validation.py).

The property of issue 10: `inbetween run` exits 0 (frames written), or exits 2 with exactly one
`error:` line; never a traceback, never another status, never a hang. Each case starts from a warm
copy of the tiny shot, so a mutation that leaves the stages' inputs alone costs no stage, and one
that changes them runs exactly the stages it touches.
"""
from __future__ import annotations

import json
import re
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, event, given, note, settings
from hypothesis import strategies as st

from .conftest import SHOT, cli, clone_warm
from .mutations import shot_mutation

pytestmark = pytest.mark.slow

HANG_SECONDS = 900  # a run of the tiny shot takes a minute or two on two busy cores


# derandomized: the same 8 cases in every CI run; no shrinking: a case costs seconds to minutes, and the
# failing case is printed whole (its shot.json edits and image corruptions) with a reproduce blob
@settings(max_examples=8, deadline=None, database=None, derandomize=True, print_blob=True,
          phases=[Phase.explicit, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                 HealthCheck.data_too_large])
@given(data=st.data())
def test_cli_exits_0_or_2_with_one_error_line(warm_source, data):
    base = json.loads((warm_source[0] / "shot.json").read_text())
    mutate = data.draw(shot_mutation(base, images=("key0.png", "key1.png")))
    with tempfile.TemporaryDirectory() as tmp:
        w = clone_warm(*warm_source, Path(tmp))
        mutate(w.shot)
        note(mutate.description)
        done = cli(w.home, "run", str(w.shot), "--out", str(Path(tmp) / "out"), timeout=HANG_SECONDS)
        event(f"exit {done.returncode}")
        assert "Traceback" not in done.stdout + done.stderr, mutate.description
        errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
        others = [line for line in done.stderr.splitlines() if not line.startswith("error:")]
        assert all(re.match(rf"^{SHOT}\s+\[", line) for line in others), done.stderr
        if done.returncode == 0:
            report = json.loads((Path(tmp) / "out" / "report.json").read_text())
            assert not errors and len(list((Path(tmp) / "out" / "frames").glob("*.png"))) == report["frames"]
        else:
            assert done.returncode == 2 and len(errors) == 1, (mutate.description, done.stderr)
