"""The editor in a real Chromium (Debian's, through Playwright), on a copy of a warm half-size arm_cross.

Each test leaves a screenshot in tests/editor/artifacts/<test>.png.
"""
from __future__ import annotations

import json
import time

import cv2
import numpy as np
import pytest

from assets.graph import shot_graph

from .conftest import call, call_json

STAGES, PARENTS = shot_graph(2).stages, shot_graph(2).parents

pytestmark = pytest.mark.slow

SCREEN_OF = """([k, x, y]) => {
  const v = window.editorApp.keys[k];
  const r = v.canvas.getBoundingClientRect();
  const [sx, sy] = v.view.toScreen(x, y);
  return [r.left + sx, r.top + sy, v.view.zoom];
}"""


def screen(page, k: int, x: float, y: float) -> tuple[float, float, float]:
    """Page coordinates of image point (x, y) on keyframe k's canvas, and the zoom (CSS px per image px)."""
    return tuple(page.evaluate(SCREEN_OF, [k, x, y]))


def until(page, js: str, timeout: float = 60) -> None:
    """Poll a JS arrow function until it returns true (the page's CSP forbids wait_for_function's eval)."""
    end = time.time() + timeout
    while not page.evaluate(js):
        assert time.time() < end, f"timed out waiting for {js}"
        page.wait_for_timeout(100)


def drag(page, start, end, steps=8) -> None:
    page.mouse.move(*start)
    page.mouse.down()
    page.mouse.move(*end, steps=steps)
    page.mouse.up()


def downstream_of(source: str) -> set[str]:
    out: set[str] = set()
    for s in STAGES:
        if any(p == source or p in out for p in PARENTS[s]):
            out.add(s)
    return out


def frames(url: str) -> list[bytes]:
    info = call_json(url + "/api/frames")[1]
    return [call(url + f"/api/frames/{i}.png")[2] for i in range(info["count"])]


def test_drag_key1_t_junction_save_reruns_only_downstream_and_frames_change(page, editor_process):
    url, shot_dir, _ = editor_process
    saved = json.loads((shot_dir / "shot.json").read_text())
    x, y = saved["t_junctions"][1][0]
    before_frames = frames(url)
    old_version = page.get_attribute("#frames-badge", "data-version")
    sx, sy, zoom = screen(page, 1, x, y)
    drag(page, (sx, sy), (sx + 3 * zoom, sy + 2 * zoom))
    assert page.get_attribute("#save", "data-dirty") == "1"
    # before saving, the page marks what the save will rerun
    will = {li.get_attribute("data-stage") for li in page.query_selector_all("#stage-list li.willrun")}
    assert will == downstream_of("key1/t_junctions")
    page.click("#save")
    page.wait_for_selector("#run-state[data-state='done'][data-seq='1']", timeout=400_000)
    now = json.loads((shot_dir / "shot.json").read_text())
    assert now["t_junctions"][1][0] == pytest.approx([x + 3, y + 2], abs=0.11)
    assert json.loads((shot_dir / "shot.json.bak").read_text()) == saved
    status = call_json(url + "/api/status")[1]
    ran = {n for n, s in status["stages"].items() if not s["cached"]}
    assert "key1/refined_masks" in ran and ran <= downstream_of("key1/t_junctions")
    assert not ran & {"key0/masks", "key0/refined_masks", "key0/template", "key1/masks"}
    shown = {li.get_attribute("data-stage"): li.get_attribute("data-state") for li in page.query_selector_all("#stage-list li")}
    assert {n for n, s in shown.items() if s == "ran"} == ran
    after_frames = frames(url)
    assert len(after_frames) == len(before_frames) and after_frames != before_frames
    # the results view refreshed to the new frames
    until(page, f"() => document.querySelector('#frames-badge').dataset.version !== '{old_version}'", 30)
    assert page.get_attribute("#frames-badge", "data-version") == status["frames_version"]
    page.click(".tab[data-view=results]")
    page.wait_for_timeout(500)


def test_paint_an_occlusion_region_and_find_it_in_shot_json(page, editor_process):
    url, shot_dir, _ = editor_process
    page.select_option("#mask-key", "1")
    page.click("#new-region")
    page.click("#tools button[data-tool=paint]")
    a, b = screen(page, 1, 88, 100), screen(page, 1, 104, 100)
    drag(page, a[:2], b[:2])
    assert page.locator("#layers .layer.active .name").inner_text().startswith("region 0")
    with page.expect_response(lambda r: r.url.endswith("/api/shot") and r.request.method == "PUT") as put:
        page.click("#save")
    assert put.value.status == 200
    shot = json.loads((shot_dir / "shot.json").read_text())
    assert shot["masks"]["occlusion"] == [[], ["key1_occ0.png"]] and shot["masks"]["foreground"] == [None, None]
    mask = cv2.imread(str(shot_dir / "key1_occ0.png"), cv2.IMREAD_UNCHANGED)
    assert mask.dtype == np.uint8 and mask.shape == (192, 192)
    assert set(np.unique(mask)) == {0, 255}
    assert mask[100, 96] == 255 and mask[100, 60] == 0 and mask[20, 96] == 0
    inside = np.argwhere(mask == 255)
    assert inside[:, 0].min() >= 100 - 10 and inside[:, 0].max() <= 100 + 10  # the 8 px brush, no more
    assert page.locator("#layers .layer.active .name").inner_text().endswith("key1_occ0.png")
    assert call_json(url + "/api/status")[1]["reason"] == "save"


def test_joint_dragged_off_the_canvas_shows_the_error_and_writes_nothing(page, editor_process):
    url, shot_dir, _ = editor_process
    before = (shot_dir / "shot.json").read_bytes()
    hand = json.loads(before)["poses"][0]["joints"][5]  # r_hand of key0
    sx, sy, _ = screen(page, 0, hand[0], hand[1])
    left = page.evaluate("document.querySelector('.keypane[data-k=\"0\"] canvas').getBoundingClientRect().left")
    drag(page, (sx, sy), (left - 120, sy))  # out of the canvas, over the tool panel
    page.click("#save")
    bar = page.locator("#error-bar")
    bar.wait_for(state="visible")
    assert "poses[0].joints[5]" in bar.inner_text() and "outside" in bar.inner_text()
    bubble = page.locator(".keypane[data-k='0'] .bubble.error")
    assert bubble.is_visible() and bubble.get_attribute("data-field") == "poses[0].joints[5]"
    assert "'r_hand'" in bubble.inner_text()
    assert (shot_dir / "shot.json").read_bytes() == before
    assert not (shot_dir / "shot.json.bak").exists()
    assert call_json(url + "/api/status")[1]["seq"] == 0
    # undo brings the joint back and the save goes through
    page.keyboard.press("Control+z")
    assert page.evaluate("window.editorApp.doc.shot.poses[0].joints[5]") == hand


def test_repose_drag_updates_the_view_and_adds_the_pose(page, editor_process):
    url, shot_dir, _ = editor_process
    page.click(".tab[data-view=pose]")
    until(page, "() => +document.querySelector('#pose-stats').dataset.updates >= 1")
    image = """() => { const b = window.editorApp.pose.image; const c = document.createElement('canvas');
      c.width = b.width; c.height = b.height; c.getContext('2d').drawImage(b, 0, 0); return c.toDataURL(); }"""
    first = page.evaluate(image)
    updates = int(page.get_attribute("#pose-stats", "data-updates"))
    hand = page.evaluate("""() => { const p = window.editorApp.pose; const r = p.canvas.getBoundingClientRect();
      const [x, y] = p.view.toScreen(p.pose[5][0], p.pose[5][1]); return [r.left + x, r.top + y, p.pose[5]]; }""")
    drag(page, hand[:2], (hand[0] + 40, hand[1] - 30), steps=10)
    until(page, f"() => +document.querySelector('#pose-stats').dataset.updates > {updates} "
                "&& !window.editorApp.pose.inflight")
    assert page.evaluate(image) != first  # the template itself was deformed, not only the skeleton drawn
    moved = page.evaluate("window.editorApp.pose.pose[5]")
    assert moved[0] > hand[2][0] + 10 and moved[1] < hand[2][1] - 5
    page.click("#pose-add")
    page.click("#save")
    page.wait_for_selector("#run-state[data-state='running'][data-seq='1'], #run-state[data-seq='1']")
    shot = json.loads((shot_dir / "shot.json").read_text())
    added = [p for p in shot["poses"] if p["t"] == 0.5]
    assert len(added) == 1 and added[0]["joints"][5][:2] == pytest.approx(moved[:2], abs=0.11)
