"""GET /api/proposals: a key's T-junction proposals, none near a click (a click wins), cached per key by what
they are computed from, a bad key refused in one line."""
from __future__ import annotations

import json
import time

import numpy as np
import pytest

from assets.run.junctions import key_proposals
from editor.proposals import CLICK_WINS_PX
from ops.shotio.load import load_shot

from .conftest import call_json

pytestmark = pytest.mark.slow


def _xy(got: dict) -> np.ndarray:
    return np.array([[p["x"], p["y"]] for p in got["proposals"]], float).reshape(-1, 2)


def test_proposals_leave_out_clicks_and_are_cached(serve, small_shot):
    s = serve(small_shot)
    clicks = np.asarray(json.loads((small_shot / "shot.json").read_text())["t_junctions"][1], float)
    t0 = time.perf_counter()
    status, got = call_json(s.url + "/api/proposals?key=1")
    first = time.perf_counter() - t0
    assert status == 200 and got["key"] == 1 and not got["cached"]
    xy = _xy(got)
    assert len(xy), "no proposal away from the clicks"
    assert (np.linalg.norm(xy[:, None] - clicks[None], axis=2) > CLICK_WINS_PX).all()  # a click wins
    # the generator's junctions are what the ink shows: the ones the clicks stand for are left out, not lost
    every = key_proposals(load_shot(small_shot), 1)
    assert got["hidden_by_clicks"] >= 1 and len(xy) + got["hidden_by_clicks"] == len(every.points)
    scores = [p["score"] for p in got["proposals"]]
    assert scores == sorted(scores, reverse=True) and all(got["min_score"] <= v <= 1 for v in scores)
    assert all(p["region"] >= -1 and abs(np.hypot(*p["stem"]) - 1) < 0.01 for p in got["proposals"])

    t0 = time.perf_counter()
    status, again = call_json(s.url + "/api/proposals?key=1")
    assert status == 200 and again["cached"] and again["proposals"] == got["proposals"]
    assert time.perf_counter() - t0 < max(0.5, first / 3)

    # the clicks removed: still the cached computation (clicks are not what proposals come from), none hidden
    data = json.loads((small_shot / "shot.json").read_text())
    data["t_junctions"][1] = []
    (small_shot / "shot.json").write_text(json.dumps(data))
    status, bare = call_json(s.url + "/api/proposals?key=1")
    assert status == 200 and bare["cached"] and bare["hidden_by_clicks"] == 0
    assert len(bare["proposals"]) == len(every.points)

    status, key0 = call_json(s.url + "/api/proposals?key=0")  # a key without clicks: computed for it, not cached
    assert status == 200 and key0["key"] == 0 and not key0["cached"] and key0["hidden_by_clicks"] == 0


@pytest.mark.parametrize("query, field", [("?key=2", "key"), ("?key=one", "key"), ("", "key"), ("?key=-1", "key")])
def test_a_bad_key_is_one_line(serve, small_shot, query, field):
    s = serve(small_shot)
    status, got = call_json(s.url + "/api/proposals" + query)
    assert status == 400 and got["field"] == field
    assert "\n" not in got["error"] and "/api/proposals" in got["error"]
