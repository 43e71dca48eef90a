"""The editor in a real Chromium, driven with real pointer events, on small shots that need no pipeline run (the
in-process server of test_api.py, reruns played by fake_run.py): the joint check, the stage warnings at what
they name, the rerun panel after a reload and while a long stage runs, the help dialog in a short window, a
shot.json the loader refuses, and making a skeleton from nothing.

Each test leaves a screenshot in tests/editor/artifacts/<test>.png.
"""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy import ndimage

from ops.segmentation.foreground import segment_foreground
from ops.shotio.image_io import read_image, to_rgba
from ops.shotio.load import load_shot
from ops.skeleton.templates import HUMANOID
from ops.warning_subject import about

from .conftest import ARTIFACTS, call_json
from .test_api import _blank_paper_point
from .test_browser import drag, screen, until

pytestmark = pytest.mark.slow


@dataclasses.dataclass
class _Output:
    x: np.ndarray


def _joint_xy(page, k: int, j: int) -> list[float]:
    return page.evaluate(f"window.editorApp.doc.keyPose({k})[{j}].slice(0, 2)")


def test_joint_dragged_onto_blank_paper_is_refused_at_the_joint(serve, small_shot, open_page):
    s = serve(small_shot)
    page = open_page(s.url)
    before = (small_shot / "shot.json").read_bytes()
    hand = json.loads(before)["poses"][-1]["joints"][5]  # key1's r_hand
    x, y = _blank_paper_point(small_shot, 1)
    a, b = screen(page, 1, hand[0], hand[1]), screen(page, 1, x, y)
    drag(page, a[:2], b[:2])
    page.click("#save")
    bubble = page.locator(".keypane[data-k='1'] .bubble.error")
    bubble.wait_for(state="visible")
    assert bubble.get_attribute("data-field") == "poses[8].joints[5]"
    assert "'r_hand'" in bubble.inner_text() and "blank paper" in bubble.inner_text()
    box = bubble.bounding_box()  # at the joint: its arrow points at the dragged joint's screen position
    b = screen(page, 1, x, y)  # (the error bar above moved the panes down)
    assert abs(box["y"] + box["height"] / 2 - b[1]) < 40 and min(abs(box["x"] - b[0]), abs(box["x"] + box["width"] - b[0])) < 30
    assert (small_shot / "shot.json").read_bytes() == before
    assert call_json(s.url + "/api/status")[1]["seq"] == 0  # no rerun started


def test_stage_warnings_show_at_what_they_name_with_their_fix(serve, small_shot, open_page):
    s = serve(small_shot)
    data = json.loads((small_shot / "shot.json").read_text())
    tj, hand = data["t_junctions"][1][0], data["poses"][-1]["joints"][5]
    warnings = [
        about("joint", "lies far outside the foreground (9.2 px)", name="r_hand", at=hand[:2],
              fix="move it onto the drawing"),
        about("T-junction", "was 33.4 px from every occlusion region; region 0 grown to meet it", at=tj),
        about("bones", "bodies overlap on 120 px but the bones have equal depth, so no occlusion was predicted there",
              name=("r_hip-r_knee", "l_hip-l_knee"), at=(96, 150), fix="give the joints different z or paint an "
              "occlusion mask"),
        "merged 2 duplicate input vertex(es)",
    ]
    s.state.store.write("key1/template", s.state.partition, _Output(np.zeros(1)),
                        provenance={"warnings": warnings})
    page = open_page(s.url)
    until(page, "() => document.querySelectorAll(\".keypane[data-k='1'] .bubble.warning\").length === 3", 20)
    bubbles = page.locator(".keypane[data-k='1'] .bubble.warning")
    by_kind = {bubbles.nth(i).get_attribute("data-kind"): bubbles.nth(i) for i in range(3)}
    assert set(by_kind) == {"joint", "T-junction", "bones"}
    # compact until the pointer is on the ring: then whole, with the fix
    assert "fix:" not in by_kind["bones"].inner_text() and "bodies overlap" in by_kind["bones"].inner_text()
    for kind, fix, (x, y) in (("bones", "fix: give the joints different z", (96, 150)),
                              ("joint", "fix: move it onto the drawing", hand[:2])):
        page.mouse.move(*screen(page, 1, x, y)[:2])
        until(page, f"() => document.querySelector(\".keypane[data-k='1'] .bubble.warning[data-kind='{kind}']\")"
                    ".classList.contains('open')", 5)
        assert fix in by_kind[kind].inner_text()
    page.mouse.move(5, 5)
    assert page.locator(".keypane[data-k='1'] .bubble.warning.open").count() == 0
    assert by_kind["T-junction"].get_attribute("data-subject") == "tj:0"
    notes = page.locator(".keypane[data-k='1'] .notes")
    assert notes.is_visible() and "merged 2 duplicate" in notes.inner_text()
    assert page.locator(".stagelist li[data-stage='key1/template'] .w").get_attribute("data-count") == "4"
    assert page.locator(".keypane[data-k='0'] .bubble.warning").count() == 0
    # the joint's warning stays with the joint while it is dragged (placed by name, not where the stage saw it)
    assert by_kind["joint"].get_attribute("data-at") == f"{hand[0]:.1f},{hand[1]:.1f}"
    sx, sy, zoom = screen(page, 1, hand[0], hand[1])
    drag(page, (sx, sy), (sx, sy + 12 * zoom))
    page.wait_for_timeout(200)
    moved = _joint_xy(page, 1, 5)
    assert abs(moved[1] - hand[1] - 12) < 0.6
    joint = page.locator(".keypane[data-k='1'] .bubble.warning[data-kind='joint']")
    assert joint.get_attribute("data-at") == f"{moved[0]:.1f},{moved[1]:.1f}"
    for i in range(3):  # every bubble inside its pane
        box, pane = bubbles.nth(i).bounding_box(), page.locator(".keypane[data-k='1']").bounding_box()
        assert pane["x"] <= box["x"] and box["x"] + box["width"] <= pane["x"] + pane["width"] + 1
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "test_stage_warnings_shown.png"))
    page.click("#overlays input[data-overlay='warnings']")  # and they can be hidden
    assert page.locator(".bubble.warning").count() == 0


def test_many_warnings_on_one_keyframe_stay_compact_apart_and_inside_until_one_is_pointed_at(
        serve, small_shot, open_page):
    s = serve(small_shot)
    data = json.loads((small_shot / "shot.json").read_text())
    joints = data["poses"][-1]["joints"]
    # six bubbles whose rings crowd the figure's lower half (192 px): stacked downward they would run off the pane
    points = [(joints[j][0], min(joints[j][1] + 40, 188)) for j in (0, 2, 5, 8, 11, 14)]
    warnings = [about("bone", f"key1's lane tears here, case {i}: a long explanation of what the stage saw, of the "
                      "part of the drawing involved and of why the motion pulls it apart", name=f"b{i}", at=p,
                      fix=f"click the T-junctions of case {i}") for i, p in enumerate(points)]
    s.state.store.write("seg0/key1/deformed_frames", s.state.partition, _Output(np.zeros(1)),
                        provenance={"warnings": warnings})
    page = open_page(s.url)
    sel = ".keypane[data-k='1'] .bubble.warning"
    until(page, f"() => document.querySelectorAll(\"{sel}\").length === 6", 20)
    bubbles = page.locator(sel)
    pane = page.locator(".keypane[data-k='1'] .bubbles").bounding_box()
    boxes = [bubbles.nth(i).bounding_box() for i in range(6)]
    for i, b in enumerate(boxes):
        assert "fix:" not in bubbles.nth(i).inner_text()  # compact: no fix, two lines of the problem at most
        assert b["height"] < 3 * 16 + 8, b
        assert pane["x"] - 1 <= b["x"] and b["x"] + b["width"] <= pane["x"] + pane["width"] + 1
        assert pane["y"] - 1 <= b["y"] and b["y"] + b["height"] <= pane["y"] + pane["height"] + 1, (b, pane)
        for c in boxes[:i]:  # apart
            assert (b["x"] >= c["x"] + c["width"] or c["x"] >= b["x"] + b["width"]
                    or b["y"] >= c["y"] + c["height"] or c["y"] >= b["y"] + b["height"]), (b, c)
    # the pointer on a ring opens that bubble whole, over the others; on its box it stays open; away, all compact
    for i in (4, 1):
        page.mouse.move(*screen(page, 1, *points[i])[:2])
        until(page, f"() => document.querySelectorAll(\"{sel}.open\").length === 1", 5)
        opened = page.locator(f"{sel}.open")
        assert f"fix: click the T-junctions of case {i}" in opened.inner_text()
        assert opened.evaluate("b => getComputedStyle(b).zIndex") == "1"
        if i == 4:
            ARTIFACTS.mkdir(exist_ok=True)
            page.screenshot(path=str(ARTIFACTS / "test_a_crowded_keyframes_warning_opened.png"))
        box = opened.bounding_box()
        assert pane["y"] - 1 <= box["y"] and box["y"] + box["height"] <= pane["y"] + pane["height"] + 1
        page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] - 3)
        page.wait_for_timeout(100)
        assert f"case {i}" in page.locator(f"{sel}.open").inner_text()
    page.mouse.move(5, 5)
    until(page, f"() => document.querySelectorAll(\"{sel}.open\").length === 0", 5)


def test_after_a_reload_the_panel_says_stale_when_the_plan_has_stale_stages(serve, small_shot, open_page, home):
    from assets.graph import shot_graph

    STAGES = shot_graph(2).stages

    # the last rerun finished ("done") but the store holds nothing for the saved shot (a cleared store, a shot
    # edited by hand, new code): the plan lists every stage as missing
    work = home / "editor" / "arm_cross"
    work.mkdir(parents=True)
    (work / "rerun.json").write_text(json.dumps({
        "state": "done", "seq": 3, "reason": "save", "error": None, "started": 1.0, "finished": 2.0,
        "stages": {n: {"cached": False, "seconds": 1.0} for n in STAGES}}))
    s = serve(small_shot)
    assert call_json(s.url + "/api/status")[1]["state"] == "done"
    page = open_page(s.url)
    until(page, "() => document.querySelector('#run-state').dataset.state !== 'done'", 30)
    assert page.get_attribute("#run-state", "data-state") == "stale"
    assert page.inner_text("#run-state") == f"{len(STAGES)} stale"
    rows = {li.get_attribute("data-stage"): li.get_attribute("data-state") for li in page.query_selector_all("#stage-list li")}
    assert set(rows.values()) == {"missing"}, rows


def test_the_panel_names_the_running_stage_and_its_progress_while_earlier_steps_report(serve, small_shot, open_page):
    s = serve(small_shot, "--ahead", "--sleep", "1.0")
    page = open_page(s.url)
    page.click("#run")
    # the last stage started ahead of the steps before it: named from the first of their reports on
    until(page, "() => document.querySelector(\"#stage-list li[data-stage='key1/template'] .st\")"
                "?.textContent.startsWith('re-ran')", 20)
    assert page.inner_text("#run-state") == "running inbetween_frames"
    until(page, "() => document.querySelector(\"#stage-list li[data-stage='inbetween_frames'] .st\")"
                "?.textContent.includes('/≤4')", 20)
    row = page.locator("#stage-list li[data-stage='inbetween_frames']")
    assert row.get_attribute("data-state") == "running" and row.locator(".bar").count() == 1
    page.wait_for_selector("#run-state[data-state='done'], #run-state[data-state='stale']", timeout=30_000)


def test_the_help_fits_a_1000_px_window_and_closes(serve, small_shot, open_page):
    s = serve(small_shot)
    page = open_page(s.url, height=1000, width=1280)
    page.click("#help-open")
    close = page.locator("#help-close")
    box, body = close.bounding_box(), page.locator(".modal-body").bounding_box()
    assert body["y"] >= 0 and body["y"] + body["height"] <= 1000
    assert box["y"] >= body["y"] and box["y"] + box["height"] <= body["y"] + body["height"] <= 1000
    scroll = page.locator(".modal-scroll")
    assert scroll.evaluate("e => e.scrollHeight > e.clientHeight")  # the text is longer than the window: it scrolls
    page.mouse.move(body["x"] + 100, body["y"] + 100)
    page.mouse.wheel(0, 5000)
    page.wait_for_timeout(200)
    last = page.locator(".helptext li").last.bounding_box()
    assert last["y"] + last["height"] <= box["y"]  # the last line reachable above the Close button
    page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    assert page.locator("#help").is_hidden()


def _foreground(shot_dir, k: int) -> np.ndarray:
    shot = load_shot(shot_dir)
    return segment_foreground(to_rgba(read_image(shot.keyframes[k])), shot.key_pose(k), shot.skeleton).mask


def test_a_shot_without_skeleton_opens_and_a_skeleton_is_made_and_saved(serve, small_shot, open_page):
    fgs = [_foreground(small_shot, k) for k in (0, 1)]  # the character, from the sample's own poses
    fg = fgs[0]
    ys, xs = (v.astype(float) for v in np.nonzero(fg))
    (small_shot / "shot.json").write_text(json.dumps({"format": "inbetween-shot/1", "keyframes": ["key0.png", "key1.png"]}))
    s = serve(small_shot)
    page = open_page(s.url)
    # the loader's message at the field it names
    err = page.locator("#skeleton-panel .field-error")
    assert err.is_visible() and "missing or not an object" in err.inner_text()
    assert page.evaluate("window.editorApp.doc.jointNames().length") == 0
    # a humanoid placed with a drag of its box around the character on key0
    page.select_option("#template", "humanoid")
    a, b = screen(page, 0, xs.min(), ys.min()), screen(page, 0, xs.max(), ys.max())
    drag(page, a[:2], b[:2], steps=12)
    names = page.evaluate("window.editorApp.doc.jointNames()")
    assert names == list(HUMANOID.joints)
    got = np.array(page.evaluate("window.editorApp.doc.keyPose(0)"))[:, :2]
    want = [xs.min(), ys.min()] + HUMANOID.positions * [xs.max() - xs.min(), ys.max() - ys.min()]
    np.testing.assert_allclose(got, want, atol=1.5)  # the template's unit box is the dragged box
    assert page.locator("#skeleton-panel .field-error").count() == 0  # an edit clears the old message
    # add a joint by a click on the drawing: the child of the selected joint
    page.click("#tools button[data-tool=select]")
    neck = names.index("neck")
    nx, ny = _joint_xy(page, 0, neck)
    page.mouse.click(*screen(page, 0, nx, ny)[:2])  # select the neck
    page.click("#tools button[data-tool=skeleton]")
    head = [float(nx), float(ny) - 12]
    while not fg[int(round(head[1])), int(round(head[0]))]:
        head[1] += 1
    page.mouse.click(*screen(page, 0, *head)[:2])
    assert page.evaluate("window.editorApp.doc.jointNames().length") == 17
    j = 16
    assert page.evaluate(f"window.editorApp.doc.parents()[{j}]") == neck
    page.fill("#joint-name", "head")
    page.press("#joint-name", "Enter")
    assert page.evaluate(f"window.editorApp.doc.jointNames()[{j}]") == "head"
    # re-parent: a bone drawn from the torso onto left_shoulder makes the torso its parent (it was already:
    # draw it from the neck instead, then back)
    torso, shoulder = names.index("torso"), names.index("left_shoulder")
    pts = [screen(page, 0, *_joint_xy(page, 0, i))[:2] for i in (neck, shoulder, torso)]
    drag(page, pts[0], pts[1])
    assert page.evaluate(f"window.editorApp.doc.parents()[{shoulder}]") == neck
    drag(page, pts[1], pts[0])  # the neck under its own child: a loop, refused, nothing changes
    assert page.evaluate(f"window.editorApp.doc.parents()[{neck}]") == torso
    assert "loop" in page.inner_text("#dirty")
    drag(page, pts[2], pts[1])
    assert page.evaluate(f"window.editorApp.doc.parents()[{shoulder}]") == torso
    # delete a joint: root and hip share a spot; delete the hip (its child, the torso, moves up to the root)
    hip = names.index("hip")
    page.click("#tools button[data-tool=select]")
    page.evaluate(f"window.editorApp.select({{k: 0, kind: 'joint', index: {hip}}})")
    page.click("#joint-delete")
    names = page.evaluate("window.editorApp.doc.jointNames()")
    assert "hip" not in names and len(names) == 16
    parents = page.evaluate("window.editorApp.doc.parents()")
    assert parents[names.index("torso")] == names.index("root")
    # key1 starts from key0's pose
    page.click(".keypane[data-k='0'] canvas", position={"x": 5, "y": 5})  # focus key0 (paper: nothing picked)
    page.click("#copy-pose")
    assert page.evaluate("JSON.stringify(window.editorApp.doc.keyPose(1)) === JSON.stringify(window.editorApp.doc.keyPose(0))")
    # save; joints the template put on blank paper are refused one by one at the joint, and dragged onto the drawing
    nearest = [ndimage.distance_transform_edt(~f, return_indices=True)[1] for f in fgs]
    for _ in range(2 * len(names) + 1):
        with page.expect_response(lambda r: r.url.endswith("/api/shot") and r.request.method == "PUT") as put:
            page.click("#save")
        if put.value.status == 200:
            break
        field = put.value.json()["field"]
        assert put.value.status == 400 and "blank paper" in put.value.json()["error"], put.value.json()
        bubble = page.locator(".bubble.error")
        bubble.wait_for(state="visible")
        i, j = (int(v) for v in field.removeprefix("poses[").removesuffix("]").split("].joints["))
        k = 0 if i == 0 else 1
        x, y = _joint_xy(page, k, j)
        r, c = (float(v) for v in nearest[k][:, int(round(y)), int(round(x))])
        drag(page, screen(page, k, x, y)[:2], screen(page, k, c + 0.3, r + 0.3)[:2])
    assert put.value.status == 200
    saved = json.loads((small_shot / "shot.json").read_text())
    shot = load_shot(small_shot)  # a valid shot.json
    assert list(shot.skeleton.joints) == names and saved["skeleton"]["parents"] == parents
    assert [p["t"] for p in saved["poses"]] == [0, 1]


SKELETON_JS = """async () => {
  const S = await import('/static/js/skeleton.js');
  const out = {};
  // format v2: three keys at frames 0, 8, 20 and one pose between
  const shot = {format: 'inbetween-shot/2', keyframes: ['a.png', 'b.png', 'c.png'], key_frames: [0, 8, 20]};
  S.ensureSkeleton(shot);
  out.keyPoses = S.keyPoseIndices(shot);
  const root = S.addJoint(shot, 0, 10, 10, -1, 'root');
  shot.poses.splice(2, 0, {frame: 14, joints: [[30, 10, 0]]});
  shot.poses[1].joints[0] = [20, 10, 0];
  shot.poses[3].joints[0] = [40, 10, 0];
  const hand = S.addJoint(shot, 2, 45, 12, root);  // placed on key 2 at an offset (5, 2) from the root
  out.hand = shot.poses.map((p) => p.joints[hand]);
  try { S.addJoint(shot, 0, 1, 1, -1); } catch (e) { out.secondRoot = e instanceof S.SkeletonError; }
  const tip = S.addJoint(shot, 0, 20, 20, hand, 'tip');
  try { S.reparent(shot, hand, tip); } catch (e) { out.loop = e.message; }
  S.deleteJoint(shot, hand);
  out.afterDelete = [shot.skeleton.joints, shot.skeleton.parents, shot.poses.map((p) => p.joints.length)];
  S.copyPose(shot, 0, 2);
  out.copied = JSON.stringify(shot.poses[3].joints) === JSON.stringify(shot.poses[0].joints);
  const tpl = {joints: ['a', 'b'], parents: [-1, 0], positions: [[0, 0], [1, 0.5]]};
  out.replaced = S.applyTemplate(shot, tpl, 1, [100, 50, 0, 150]);  // a box dragged from bottom right to top left
  out.afterTemplate = shot.poses.map((p) => [p.frame, p.joints]);
  out.placedOnlyKey2 = !S.applyTemplate(shot, tpl, 2, [0, 0, 10, 10]) && shot.poses[2].joints[1][0] === 10
    && shot.poses[0].joints[1][0] === 100;
  return out;
}"""


def test_skeleton_editing_keeps_every_pose_in_step_and_assumes_no_two_keys(serve, small_shot, open_page):
    page = open_page(serve(small_shot).url)
    out = page.evaluate(SKELETON_JS)
    assert out["keyPoses"] == [0, 1, 2]
    # the new joint keeps key 2's offset from its parent in every pose
    assert out["hand"] == [[15, 12, 0], [25, 12, 0], [35, 12, 0], [45, 12, 0]]
    assert out["secondRoot"] is True and "loop" in out["loop"]
    assert out["afterDelete"] == [["root", "tip"], [-1, 0], [2, 2, 2, 2]]  # the tip now hangs from the root
    assert out["copied"] is True
    assert out["replaced"] is True
    # a new skeleton: the pose between the keys goes, every key pose is the box's (normalized corner order)
    assert out["afterTemplate"] == [[f, [[0, 50, 0], [100, 100, 0]]] for f in (0, 8, 20)]
    assert out["placedOnlyKey2"] is True


def test_every_stage_row_shows_its_seconds_whole_however_long_its_name(serve, small_shot, open_page):
    """The rerun panel is narrow: a long stage name gives way (cut short, in full on hover), never the state
    and seconds beside it ("seg0/key0/textured_template re-ran 2.3" was cut at the panel's edge)."""
    s = serve(small_shot, "--sleep", "2.0", "--stages",
              "key1/refined_masks,seg0/key0/textured_template,seg0/key1/deformed_frames,inbetween_frames")
    page = open_page(s.url)
    page.click("#run")
    until(page, "() => document.querySelector(\"#stage-list li[data-stage='seg0/key0/textured_template'] .st\")"
                "?.textContent.startsWith('re-ran')", 30)
    rows = page.evaluate("""() => [...document.querySelectorAll('#stage-list li')].map(li => {
        const st = li.querySelector('.st').getBoundingClientRect(), box = li.getBoundingClientRect();
        const name = li.querySelector('.name');
        return [li.dataset.stage, st.left >= box.left - 0.5 && st.right <= box.right + 0.5,
                li.querySelector('.st').textContent, name.title];
    })""")
    assert rows and all(inside for _, inside, _, _ in rows), [r for r in rows if not r[1]]
    assert any(text.startswith("re-ran") for _, _, text, _ in rows)
    assert all(title == stage for stage, _, _, title in rows)


def test_a_long_stage_names_warning_count_stays_in_view(serve, small_shot, open_page):
    """The name gives way, not the ⚠ count after it ("seg0/key1/deformed_frames…" hid a torn lane's warning)."""
    s = serve(small_shot)
    torn = about("bone", "key1's lane draws 59% of the character from stretched triangles", name="r_knee-r_foot",
                 at=(96, 150), fix="click the T-junctions")
    s.state.store.write("seg0/key1/deformed_frames", s.state.partition, _Output(np.zeros(1)),
                        provenance={"warnings": [torn]})
    page = open_page(s.url, width=1300)  # a panel narrow enough to cut the name short
    sel = "#stage-list li[data-stage='seg0/key1/deformed_frames']"
    until(page, f"() => document.querySelector(\"{sel} .w\") !== null", 20)
    box = page.evaluate(f"""() => {{
        const li = document.querySelector("{sel}"), w = li.querySelector('.w'), st = li.querySelector('.st');
        const a = w.getBoundingClientRect(), c = st.getBoundingClientRect();
        const b = li.querySelector('.name').getBoundingClientRect();  // its box clips what overflows it
        return a.width > 0 && a.left >= b.left && a.right <= b.right + 0.5 && b.right <= c.left + 0.5;
    }}""")
    assert box, "the warning count is cut off"
    # the key's pane shows it at the bone, from the side's stage
    until(page, "() => document.querySelectorAll(\".keypane[data-k='1'] .bubble.warning[data-kind='bone']\").length === 1", 20)
