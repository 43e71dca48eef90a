"""T-junction proposals in a real Chromium (the in-process server, no pipeline run): shown by themselves on a key
without T-junctions, on a clicked key once the overlay is ticked, a click on one accepts it (undoable), Dismiss
hides them. The screenshot is kept in tests/editor/artifacts/<test>.png."""
from __future__ import annotations

import json

import numpy as np
import pytest

from .test_browser import screen, until

pytestmark = pytest.mark.slow

SHOWN = "(k) => (window.editorApp.keys[k].proposalsShown || []).map((p) => [p.x, p.y])"
TJ = "(k) => window.editorApp.doc.shot.t_junctions[k].map((p) => p.slice(0, 2))"


def test_proposals_toggle_accept_undo_and_dismiss(serve, small_shot, open_page):
    s = serve(small_shot)
    clicks = json.loads((small_shot / "shot.json").read_text())["t_junctions"]
    assert not clicks[0] and clicks[1]
    page = open_page(s.url)
    # key0 has no T-junctions: its proposals come by themselves; key1's clicks keep its own hidden until asked
    until(page, f"() => ({SHOWN})(0).length > 0", 90)
    assert page.evaluate(SHOWN, 1) == []
    page.click("#overlays input[data-overlay='proposals']")
    until(page, f"() => ({SHOWN})(1).length > 0", 90)
    shown = np.array(page.evaluate(SHOWN, 1))
    assert (np.linalg.norm(shown[:, None] - np.array(clicks[1])[None], axis=2) > 5).all()  # a click wins

    # click the proposal farthest from the joints (so it is what the click picks)
    joints = np.array(page.evaluate("window.editorApp.doc.keyPose(1).map((j) => j.slice(0, 2))"))
    target = shown[np.argmax(np.linalg.norm(shown[:, None] - joints[None], axis=2).min(axis=1))]
    sx, sy, _ = screen(page, 1, *target)
    page.mouse.move(sx, sy)
    page.mouse.down()
    page.mouse.up()
    after = page.evaluate(TJ, 1)
    assert len(after) == len(clicks[1]) + 1 and np.allclose(after[-1], target, atol=0.06)
    assert page.evaluate("window.editorApp.selected.kind") == "tj"
    assert not any(np.allclose(p, target) for p in page.evaluate(SHOWN, 1))  # accepted: now a T-junction
    assert page.locator("#save").get_attribute("data-dirty") == "1"
    page.click("#undo")
    assert len(page.evaluate(TJ, 1)) == len(clicks[1])
    assert any(np.allclose(p, target) for p in page.evaluate(SHOWN, 1))  # offered again

    # key1 focused (the click): Accept all >= 2 accepts nothing, Dismiss hides its proposals for the session
    page.fill("#proposals-min", "2")
    page.click("#proposals-accept-all")
    assert len(page.evaluate(TJ, 1)) == len(clicks[1])
    page.click("#proposals-dismiss")
    assert page.evaluate(SHOWN, 1) == [] and len(page.evaluate(SHOWN, 0)) > 0
    assert "dismissed" in page.inner_text("#proposals-info")
