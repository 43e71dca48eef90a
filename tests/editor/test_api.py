"""The editor's JSON API on a real server (uvicorn in a thread), reruns played by fake_run.py."""
from __future__ import annotations

import dataclasses
import json
import time

import cv2
import numpy as np
import pytest

from tests.assets.conftest import SAMPLES, scaled_copy

from .conftest import call, call_json


def png(img: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", img)
    assert ok
    return buf.tobytes()


def wait_state(url: str, state: str, timeout: float = 20) -> dict:
    end = time.time() + timeout
    while time.time() < end:
        st = call_json(url + "/api/status")[1]
        if st["state"] == state:
            return st
        time.sleep(0.05)
    raise AssertionError(f"status never became {state}: {st}")


def test_host_header_and_origin_are_checked(serve, small_shot):
    s = serve(small_shot)
    assert call(s.url + "/api/shot")[0] == 200
    assert call(s.url + "/api/shot", headers={"Host": f"localhost:{s.port}"})[0] == 200
    # DNS rebinding: the right address, someone else's name (or the loopback name without the editor's port)
    for host in (f"evil.example:{s.port}", "127.0.0.1", f"127.0.0.1:{s.port + 1}", "localhost"):
        status, _, body = call(s.url + "/api/shot", headers={"Host": host})
        assert status == 403 and b"refused" in body, host
    status, _, _ = call(s.url + "/api/run", "POST", b"{}", {"Origin": "http://evil.example"})
    assert status == 403
    assert call(s.url + "/")[1]["content-security-policy"].startswith("default-src 'self'")


def test_get_shot_is_the_file_and_a_bad_put_writes_nothing(serve, small_shot):
    s = serve(small_shot)
    before = (small_shot / "shot.json").read_bytes()
    status, shot = call_json(s.url + "/api/shot")
    assert status == 200 and shot == json.loads(before)
    shot["t_junctions"][1][1] = [500.0, 3.0]
    status, err = call_json(s.url + "/api/shot", "PUT", shot)
    assert status == 400
    assert err["field"] == "t_junctions[1][1]"
    assert err["error"].startswith(str(small_shot / "shot.json") + ": t_junctions[1][1]: ") and "fix: " in err["error"]
    assert (small_shot / "shot.json").read_bytes() == before
    assert not (small_shot / "shot.json.bak").exists()
    assert call_json(s.url + "/api/status")[1]["seq"] == 0  # nothing queued


def test_key_joint_off_the_keyframe_is_refused_with_its_field(serve, small_shot):
    s = serve(small_shot)
    shot = call_json(s.url + "/api/shot")[1]
    shot["poses"][-1]["joints"][5][0] = -40.0
    status, err = call_json(s.url + "/api/shot", "PUT", shot)
    assert status == 400 and err["field"] == "poses[8].joints[5]" and "'r_hand'" in err["error"]
    status, err = call(s.url + "/api/shot", "PUT", b"{not json", {"Content-Type": "application/json"})[:2]
    assert status == 400


def test_put_writes_atomically_keeps_backup_and_reports_its_rerun_at_once(serve, small_shot):
    s = serve(small_shot, "--sleep", "0.3")
    before = (small_shot / "shot.json").read_bytes()
    shot = call_json(s.url + "/api/shot")[1]
    shot["t_junctions"][1][0][0] += 2.0
    status, body = call_json(s.url + "/api/shot", "PUT", shot)
    assert (status, body) == (200, {"ok": True})
    st = call_json(s.url + "/api/status")[1]  # right after the 200: this PUT's rerun
    assert st["state"] == "running" and st["seq"] == 1 and st["reason"] == "save"
    assert json.loads((small_shot / "shot.json").read_text()) == shot
    assert (small_shot / "shot.json.bak").read_bytes() == before
    assert not [p for p in small_shot.iterdir() if p.name.startswith(".")]  # no temporary left behind
    st = wait_state(s.url, "done")
    assert st["stages"]["key1/refined_masks"] == {"cached": True, "seconds": 0.0}
    assert st["stages"]["inbetween_frames"] == {"cached": False, "seconds": 0.03}
    assert st["error"] is None


@pytest.mark.slow  # seconds, not milliseconds: the whole suite runs it, the edit loop does not
def test_second_put_supersedes_the_running_rerun(serve, small_shot):
    s = serve(small_shot, "--sleep", "2")
    shot = call_json(s.url + "/api/shot")[1]
    assert call_json(s.url + "/api/shot", "PUT", shot)[0] == 200
    time.sleep(0.5)
    first_pid = json.loads((s.state.workdir / "rerun.json").read_text())["pid"]
    shot["t_junctions"][1][0][1] += 1.0
    assert call_json(s.url + "/api/shot", "PUT", shot)[0] == 200
    st = call_json(s.url + "/api/status")[1]
    assert st["seq"] == 2 and st["state"] == "running" and st["stages"] == {}
    deadline = time.monotonic() + 10.0  # the new rerun's process records itself when it starts (slower under load)
    while json.loads((s.state.workdir / "rerun.json").read_text())["pid"] == first_pid:
        assert time.monotonic() < deadline, "the second PUT started no new rerun"
        time.sleep(0.1)
    with pytest.raises(ProcessLookupError):
        import os
        os.kill(first_pid, 0)
    assert wait_state(s.url, "done", 30)["seq"] == 2


def test_failed_rerun_reports_the_cli_error_line(serve, small_shot):
    s = serve(small_shot, "--fail")
    assert call_json(s.url + "/api/run", "POST", {})[0] == 200
    st = wait_state(s.url, "failed")
    assert st["error"] == "arm_cross: inbetween_frames: fake failure (full log: nowhere)"


def test_mask_upload_is_staged_normalized_and_written_by_the_put_that_names_it(serve, small_shot):
    s = serve(small_shot)
    h, w = 192, 192
    rgba = np.zeros((h, w, 4), np.uint8)
    rgba[80:110, 85:105] = 255  # white, opaque: inside
    rgba[0:10, 0:10, :3] = 255  # white but transparent: outside
    assert call(s.url + "/api/masks/key1_occ0.png", "PUT", png(rgba), {"Content-Type": "image/png"})[0] == 200
    assert not (small_shot / "key1_occ0.png").exists()  # staged, not written
    status, _, got = call(s.url + "/api/masks/key1_occ0.png")
    grey = cv2.imdecode(np.frombuffer(got, np.uint8), cv2.IMREAD_UNCHANGED)
    assert status == 200 and grey.shape == (h, w) and grey.dtype == np.uint8
    assert set(np.unique(grey)) == {0, 255} and grey[90, 90] == 255 and grey[5, 5] == 0
    for name, body, problem in (("../escape.png", png(rgba), b"inside the shot directory"),
                                ("key0.png", png(rgba), b"keyframe"),
                                ("small.png", png(rgba[:50]), b"192x50"),
                                ("junk.png", b"not an image", b"readable")):
        status, _, err = call(s.url + "/api/masks/" + name, "PUT", body, {"Content-Type": "image/png"})
        assert status == 400 and problem in err, name
    shot = call_json(s.url + "/api/shot")[1]
    assert "masks" not in shot  # absent masks stay absent on a plain save
    shot["masks"] = {"foreground": [None, None], "occlusion": [[], ["key1_occ0.png"]]}
    assert call_json(s.url + "/api/shot", "PUT", shot)[0] == 200
    written = cv2.imread(str(small_shot / "key1_occ0.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(written, grey)


def test_put_naming_a_missing_mask_is_refused(serve, small_shot):
    s = serve(small_shot)
    shot = call_json(s.url + "/api/shot")[1]
    shot["masks"] = {"foreground": [None, None], "occlusion": [[], ["key1_occ7.png"]]}
    status, err = call_json(s.url + "/api/shot", "PUT", shot)
    assert status == 400 and err["field"] == "masks.occlusion[1][0]" and "does not exist" in err["error"]


def test_predicted_masks_without_a_run(serve, small_shot):
    s = serve(small_shot)
    status, info = call_json(s.url + "/api/predicted/1")
    assert status == 200 and info["source"] == "computed" and info["regions"] >= 1
    status, _, fg = call(s.url + "/api/predicted/1/foreground.png")
    fg = cv2.imdecode(np.frombuffer(fg, np.uint8), cv2.IMREAD_UNCHANGED)
    assert status == 200 and fg.shape == (192, 192) and 0 < (fg == 255).mean() < 0.6
    assert call(s.url + "/api/predicted/1/occlusion/99.png")[0] == 404
    assert call(s.url + "/api/refined/1")[0] == 404  # not run yet
    assert call(s.url + "/api/frames")[0] == 404
    assert call(s.url + "/api/repose", "POST", json.dumps({"k": 1, "t": 0.5, "joints": [[0, 0, 0]] * 15}).encode())[0] == 409


def test_two_poses_with_frames_interpolates_and_takes_a_new_pose(serve, tmp_path):
    shot_dir = scaled_copy(SAMPLES / "two_poses", tmp_path / "shots" / "two_poses", 0.5)
    s = serve(shot_dir)
    shot = call_json(s.url + "/api/shot")[1]
    assert len(shot["poses"]) == 2 and shot["frames"] == 9
    status, motion = call_json(s.url + "/api/motion", "POST", {})
    assert status == 200 and len(motion["times"]) == 9 and motion["given_times"] == [0.0, 1.0]
    mid = np.asarray(motion["poses"][4])
    status, at = call_json(s.url + "/api/motion", "POST", {"shot": shot, "times": [0.5]})
    np.testing.assert_allclose(at["poses"][0], mid, atol=1e-3)
    # "add as pose at t": the page inserts it; the shot stays valid and the pose is used from then on
    shot["poses"].insert(1, {"t": 0.5, "joints": (mid + [3.0, 0.0, 0.0]).tolist()})
    assert call_json(s.url + "/api/shot", "PUT", shot)[0] == 200
    status, motion = call_json(s.url + "/api/motion", "POST", {})
    assert motion["given_times"] == [0.0, 0.5, 1.0]
    np.testing.assert_allclose(motion["poses"][4], mid + [3.0, 0.0, 0.0], atol=1e-3)


def test_static_page_and_modules_are_served_without_a_cdn(serve, small_shot):
    s = serve(small_shot)
    status, headers, html = call(s.url + "/")
    assert status == 200 and b'type="module"' in html
    for src in [b"/static/js/main.js", b"/static/style.css"]:
        assert src in html
        assert call(s.url + src.decode())[0] == 200
    js = b"".join(call(s.url + f"/static/js/{m}.js")[2] for m in
                  ("main", "api", "doc", "keyview", "masks", "viewport", "results", "pose", "stages", "help",
                                                  "skeleton", "timeline"))
    assert b"http://" not in js and b"https://" not in js


def test_put_refuses_to_overwrite_a_shot_changed_on_disk(serve, small_shot):
    s = serve(small_shot)
    status, headers, raw = call(s.url + "/api/shot")
    etag, shot = headers["etag"], json.loads(raw)
    on_disk = json.loads((small_shot / "shot.json").read_text())
    on_disk["frames"] = 5  # someone edits the file by hand meanwhile
    (small_shot / "shot.json").write_text(json.dumps(on_disk))
    status, _, err = call(s.url + "/api/shot", "PUT", json.dumps(shot).encode(),
                          {"Content-Type": "application/json", "If-Match": etag})
    assert status == 409 and b"changed on disk" in err
    assert json.loads((small_shot / "shot.json").read_text())["frames"] == 5
    etag = call(s.url + "/api/shot")[1]["etag"]
    status, headers, _ = call(s.url + "/api/shot", "PUT", json.dumps(shot).encode(),
                              {"Content-Type": "application/json", "If-Match": etag})
    assert status == 200 and headers["etag"] != etag


def test_a_second_editor_of_the_same_shot_is_refused(serve, small_shot):
    from editor.state import EditorState
    from ops.errors import ShotError

    serve(small_shot)
    with pytest.raises(ShotError, match="already open in an editor at test"):
        EditorState(small_shot)


def _blank_paper_point(shot_dir, k: int, away: float = 20.0) -> list[float]:
    """A point of keyframe k's image at least `away` px from the predicted foreground (blank paper)."""
    from scipy import ndimage

    from ops.segmentation.foreground import segment_foreground
    from ops.shotio.image_io import read_image, to_rgba
    from ops.shotio.load import load_shot

    shot = load_shot(shot_dir)
    fg = segment_foreground(to_rgba(read_image(shot.keyframes[k])), shot.key_pose(k), shot.skeleton).mask
    d = ndimage.distance_transform_edt(~fg)
    ys, xs = np.nonzero(d[8:-8, 8:-8] > away)
    return [float(xs[len(xs) // 2] + 8), float(ys[len(ys) // 2] + 8)]


def test_joint_moved_onto_blank_paper_is_refused_at_the_joint_and_nothing_is_written(serve, small_shot):
    s = serve(small_shot)
    before = (small_shot / "shot.json").read_bytes()
    shot = call_json(s.url + "/api/shot")[1]
    x, y = _blank_paper_point(small_shot, 1)
    shot["poses"][-1]["joints"][5][:2] = [x, y]  # key1's r_hand, inside the image but off the character
    status, err = call_json(s.url + "/api/shot", "PUT", shot)
    assert status == 400 and err["field"] == "poses[8].joints[5]", err
    assert "'r_hand'" in err["error"] and "blank paper" in err["error"] and "fix: drag it onto the drawing" in err["error"]
    assert (small_shot / "shot.json").read_bytes() == before and not (small_shot / "shot.json.bak").exists()
    assert call_json(s.url + "/api/status")[1]["seq"] == 0  # no rerun
    # a joint moved along the drawing is fine, and so is one the saved shot already had off it (the CLI warns)
    shot = json.loads(before)
    shot["poses"][-1]["joints"][5][0] += 1.0
    assert call_json(s.url + "/api/shot", "PUT", shot)[0] == 200


def test_a_joint_the_saved_shot_already_had_off_the_drawing_does_not_block_a_save(serve, small_shot):
    data = json.loads((small_shot / "shot.json").read_text())
    x, y = _blank_paper_point(small_shot, 0)
    data["poses"][0]["joints"][8][:2] = [x, y]  # written by hand (or by a tool) before the editor opened
    (small_shot / "shot.json").write_text(json.dumps(data))
    s = serve(small_shot)
    data["t_junctions"][1][0][0] += 1.0
    assert call_json(s.url + "/api/shot", "PUT", data)[0] == 200
    data["poses"][0]["joints"][8][0] += 2.0  # but dragged further over the paper: refused
    status, err = call_json(s.url + "/api/shot", "PUT", data)
    assert status == 400 and err["field"] == "poses[0].joints[8]"


def test_the_joint_check_uses_the_stored_foreground_of_the_same_drawing():
    """Foregrounds picks the stored key{k}/masks foreground when it was made from this very drawing."""
    from editor.jointcheck import Foregrounds
    from ops.shotio.load import load_shot
    from ops.shotio.versions import source_versions

    shot_dir = SAMPLES / "arm_cross"
    shot = load_shot(shot_dir)
    drawing = source_versions(shot)["key1/drawing"]
    everything = np.ones(shot.size, bool)

    class FakeStore:
        parents = {"key1/drawing": drawing, "key1/pose": "some other pose"}

        def provenance(self, name, partition):
            return ("v1", {"parents": self.parents}) if name == "key1/masks" else (None, None)

        def read(self, name, partition):
            return type("Masks", (), {"foreground": everything})()

    store = FakeStore()
    assert Foregrounds(store, "p").of(shot, 1) is everything
    store.parents = {"key1/drawing": "another drawing"}
    predicted = Foregrounds(store, "p").of(shot, 1)
    assert predicted.dtype == bool and 0.02 < predicted.mean() < 0.6  # the prediction, not the stored mask


def test_warnings_come_with_their_subject_keyframe_and_fix(serve, small_shot):
    from ops.warning_subject import about

    s = serve(small_shot)
    tj = about("T-junction", "was 33.4 px from every occlusion region; region 0 grown to meet it", at=(84.5, 95.7))
    ties = about("bones", "bodies overlap on 120 px but the bones have equal depth, so no occlusion was predicted "
                 "there", name=("r_hip-r_knee", "l_hip-l_knee"), at=(96, 150), fix="give the joints different z or "
                 "paint an occlusion mask")
    whole = "merged 2 duplicate input vertex(es); fix: none needed"

    @dataclasses.dataclass
    class Output:
        x: np.ndarray

    store, out = s.state.store, Output(np.zeros(1))
    store.write("key1/masks", s.state.partition, out, provenance={"warnings": [ties]})
    store.write("key1/refined_masks", s.state.partition, out, provenance={"warnings": [ties, tj]})
    store.write("key0/template", s.state.partition, out, provenance={"warnings": [whole]})
    status, got = call_json(s.url + "/api/warnings")
    assert status == 200
    w = got["warnings"]
    assert [(x["stage"], x["k"], x["kind"]) for x in w] == [
        ("key0/template", 0, None), ("key1/masks", 1, "bones"), ("key1/refined_masks", 1, "T-junction")]
    assert w[0]["problem"] == "merged 2 duplicate input vertex(es)" and w[0]["fix"] == "none needed"
    assert w[1]["names"] == ["r_hip-r_knee", "l_hip-l_knee"] and w[1]["at"] == [96.0, 150.0]
    assert w[1]["fix"] == "give the joints different z or paint an occlusion mask"
    assert w[2]["at"] == [84.5, 95.7] and w[2]["fix"] is None and w[2]["text"] == tj


def test_check_gives_the_loaders_verdict_on_a_shot_it_refuses(serve, small_shot):
    s = serve(small_shot)
    assert call_json(s.url + "/api/check")[1] == {"ok": True, "error": None, "field": None}
    (small_shot / "shot.json").write_text(json.dumps({"format": "inbetween-shot/1", "keyframes": ["key0.png", "key1.png"]}))
    got = call_json(s.url + "/api/check")[1]
    assert got["ok"] is False and got["field"] == "skeleton" and "fix: " in got["error"]
    assert call_json(s.url + "/api/info")[1]["size"] == [192, 192]  # the page can still show the drawings
    assert call(s.url + "/api/keyframes/1.png")[0] == 200


def test_templates_route(serve, small_shot):
    s = serve(small_shot)
    status, got = call_json(s.url + "/api/templates")
    assert status == 200 and set(got) >= {"humanoid", "quadruped"}
    h = got["humanoid"]
    assert len(h["joints"]) == len(h["parents"]) == len(h["positions"]) == 16 and h["parents"].count(-1) == 1
