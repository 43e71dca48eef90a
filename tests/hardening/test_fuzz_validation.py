"""Fuzzed shots, validated in process: a Shot or one ShotError line, never another exception, never slow.

Hypothesis mutates shot.json (tree edits, raw text damage) and the images (truncated, 16-bit, palette,
greyscale, CMYK JPEG, huge dimensions, zero-size, blank page, ...). Whatever comes out, load_shot
either accepts it (and the planner's next step, the source versions, works on it) or raises exactly
one ShotError whose message is one line with a fix. The CLI on a sample of such shots is
test_fuzz_cli.py.
"""
from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings

from ops.errors import ShotError
from ops.shotio.load import load_shot
from ops.shotio.versions import source_versions

from .mutations import shot_mutation
from .shots import write_shot

pytestmark = pytest.mark.slow  # 300 cases: under a minute, but the fast tier keeps the table of bad inputs only

SECONDS_PER_CASE = 10.0  # far above a real load (~20 ms): only a hang or a count without bound reaches it


# derandomized where CI runs it (CI is set by .ci/run): the same 300 cases on every machine, so a red CI is the
# code's, never the draw's; a developer's run keeps drawing new cases
@settings(max_examples=300, deadline=None, database=None, print_blob=True, derandomize=bool(os.environ.get("CI")),
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutate=shot_mutation())
def test_load_shot_accepts_or_gives_one_line(mutate):
    with tempfile.TemporaryDirectory() as tmp:
        shot = write_shot(Path(tmp) / "shot")
        mutate(shot)
        start = time.perf_counter()
        try:
            loaded = load_shot(shot)
        except ShotError as e:
            message = str(e)
            assert "\n" not in message and "\r" not in message, message
            assert "; fix: " in message and e.field, message
            event(f"rejected: {e.field.split('[')[0]}")
        else:
            versions = source_versions(loaded)
            event("accepted")
            assert len(versions) == 8 and loaded.poses.shape[0] == len(loaded.times) >= 2
        assert time.perf_counter() - start < SECONDS_PER_CASE, mutate.description
