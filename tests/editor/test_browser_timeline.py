"""The timeline of keys in a real Chromium, on seq_arm_cross (three keys) served in-process with reruns played by
fake_run.py: the keys at their frames, selecting one shows it in the Annotate panes, adding a key from an image
file. The screenshot is kept in tests/editor/artifacts/<test>.png."""
from __future__ import annotations

import json
import shutil

import pytest

from ops.shotio.load import load_shot
from tests.assets.conftest import SAMPLES, scaled_copy

from .test_browser import until

pytestmark = pytest.mark.slow

SHOWN = "() => [...document.querySelectorAll('.keypane:not([hidden])')].map((p) => p.dataset.k).join()"


def test_timeline_selects_a_key_and_adds_one_from_an_image_file(serve, tmp_path, open_page):
    shot = scaled_copy(SAMPLES / "seq_arm_cross", tmp_path / "shots" / "seq_arm_cross", 0.5)
    image = shutil.copy(shot / "key1.png", tmp_path / "new_key.png")
    s = serve(shot)
    page = open_page(s.url)
    keys = page.locator("#tl-track .tl-key")
    assert keys.count() == 3
    assert [keys.nth(i).get_attribute("data-frame") for i in range(3)] == ["0", "8", "16"]
    boxes = [keys.nth(i).bounding_box() for i in range(3)]
    xs = [b["x"] + b["width"] / 2 for b in boxes]
    assert xs[0] < xs[1] < xs[2] and abs((xs[1] - xs[0]) - (xs[2] - xs[1])) < 2  # at their frames: 8 apart each
    assert page.evaluate(SHOWN) == "0,1"

    keys.nth(2).click()
    until(page, f"() => ({SHOWN})() === '1,2'", 20)
    assert page.locator(".tl-key.active").get_attribute("data-k") == "2"
    assert "frame 16" in page.locator(".keypane[data-k='2'] .keytitle").inner_text()
    until(page, "() => window.editorApp.drawings[2] !== null", 20)
    assert page.input_value("#key-frame") == "16"

    page.fill("#add-frame", "12")
    with page.expect_file_chooser() as chooser:
        page.click("#key-add")
    chooser.value.set_files(str(image))
    until(page, "() => document.querySelectorAll('#tl-track .tl-key').length === 4", 30)
    assert [keys.nth(i).get_attribute("data-frame") for i in range(4)] == ["0", "8", "12", "16"]
    assert page.locator(".tl-key.active").get_attribute("data-k") == "2"  # the new key, selected and shown
    assert page.evaluate(SHOWN) == "2,3"
    data = json.loads((shot / "shot.json").read_text())
    assert data["keyframes"][2] == "new_key.png" and data["key_frames"] == [0, 8, 12, 16]
    assert load_shot(shot).key_frames == (0, 8, 12, 16)
    assert page.evaluate("window.editorApp.info.stages.includes('seg2/frames')")
    assert page.locator("#error-bar").is_hidden()

    page.keyboard.press(",")  # the previous key; then move it in time with its frame field
    until(page, "() => document.querySelector('.tl-key.active').dataset.k === '1'", 10)
    page.fill("#key-frame", "10")
    page.press("#key-frame", "Enter")
    until(page, "() => document.querySelector('.tl-key[data-k=\"1\"]').dataset.frame === '10'", 30)
    assert load_shot(shot).key_frames == (0, 10, 12, 16)
