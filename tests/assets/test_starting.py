"""`inbetween new` and `inbetween motion`: v2 shots written to the spec from drawings, an AnimatedDrawings
character, a BVH clip and a video; key poses kept; bad input one line with exit status 2."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from assets import starting
from assets.cli import main
from ops.errors import ShotError
from ops.skeleton.templates import HUMANOID
from tests.ops.motion.test_retarget import ACTOR, RETARGET, bvh_text
from tests.ops.motion.test_track import write_video
from tests.ops.motion.v2_spec import check_v2
from tests.ops.skeleton.test_placement import person_drawing

SAMPLES = Path(__file__).resolve().parents[2] / "data_samples"
QUIET = lambda line: None  # noqa: E731


def swing(n=12):
    """BVH rotations: the right forearm lifts, the left arm swings forward, a knee bends."""
    return [{"RightForeArm": (0, 0, 8.0 * f), "LeftArm": (0, 6.0 * f, 0), "RightLeg": (3.0 * f, 0, 0)} for f in range(n)]


@pytest.fixture
def clip(tmp_path):
    bvh, cfg = tmp_path / "clip.bvh", tmp_path / "retarget.yaml"
    bvh.write_text(bvh_text(swing()))
    cfg.write_text(RETARGET)
    return bvh, cfg


@pytest.fixture
def character(tmp_path):
    """An AnimatedDrawings character folder made from a generated person."""
    img, truth, _ = person_drawing(4)
    d = tmp_path / "char"
    d.mkdir()
    rgba = np.concatenate([img, np.ones_like(img[..., :1])], 2)
    cv2.imwrite(str(d / "texture.png"), (rgba[..., [2, 1, 0, 3]] * 255).round().astype(np.uint8))
    mask = ((img.mean(2) < 0.97) * 255).astype(np.uint8)
    cv2.imwrite(str(d / "mask.png"), mask)
    rows = [{"name": n, "parent": None if p < 0 else HUMANOID.joints[p], "loc": [int(round(x)), int(round(y))]}
            for n, p, (x, y) in zip(HUMANOID.joints, HUMANOID.parents, truth)]
    import yaml

    (d / "char_cfg.yaml").write_text(yaml.safe_dump({"height": img.shape[0], "width": img.shape[1], "skeleton": rows}))
    return d / "char_cfg.yaml", np.array([r["loc"] for r in rows], float)


def test_two_sample_pngs_become_a_v2_shot_and_are_never_overwritten(tmp_path):
    shot = tmp_path / "shot"
    lines = []
    starting.new_from_images(shot, [SAMPLES / "arm_cross" / "key0.png", SAMPLES / "arm_cross" / "key1.png"],
                             say=lines.append)
    data = json.loads((shot / "shot.json").read_text())
    check_v2(data, shot)
    assert data["key_frames"] == [0, 8] and [p["frame"] for p in data["poses"]] == [0, 8]
    assert data["skeleton"]["joints"] == list(HUMANOID.joints)
    assert (shot / "key0.png").read_bytes() == (SAMPLES / "arm_cross" / "key0.png").read_bytes()
    assert lines[-1].startswith("next: inbetween edit") and any("sure" in x for x in lines)
    before = (shot / "shot.json").read_bytes()
    with pytest.raises(ShotError) as e:
        starting.new_from_images(shot, [SAMPLES / "arm_cross" / "key0.png"], say=QUIET)
    assert "already exists" in str(e.value) and (shot / "shot.json").read_bytes() == before


def test_key_frames_are_given_or_refused_in_one_line(tmp_path):
    img = SAMPLES / "no_occlusion" / "key0.png"
    starting.new_from_images(tmp_path / "a", [img, img], key_frames="0,12", say=QUIET)
    assert json.loads((tmp_path / "a" / "shot.json").read_text())["key_frames"] == [0, 12]
    for bad in ("0,5,9", "3,9", "0,0", "x"):
        with pytest.raises(ShotError) as e:
            starting.new_from_images(tmp_path / "b", [img, img], key_frames=bad, say=QUIET)
        assert e.value.field == "--key-frames"
    assert not (tmp_path / "b").exists()  # nothing written on bad input


def test_animated_drawings_character_driven_by_a_clip_starts_at_its_own_pose(tmp_path, character, clip):
    cfg, locs = character
    shot = tmp_path / "ad"
    starting.new_from_animated_drawings(shot, cfg, clip[0], clip[1], say=QUIET)
    data = json.loads((shot / "shot.json").read_text())
    check_v2(data, shot)
    assert data["keyframes"] == ["key0.png"] and data["key_frames"] == [0]
    assert data["masks"]["foreground"] == ["key0_fg.png"]
    assert len(data["poses"]) == 12 and [p["frame"] for p in data["poses"]] == list(range(12))
    assert np.allclose(np.array(data["poses"][0]["joints"])[:, :2], locs, atol=0.006)
    hand = HUMANOID.joints.index("right_hand")
    assert np.linalg.norm(np.subtract(data["poses"][-1]["joints"][hand][:2], locs[hand])) > 5  # the clip moves it


def test_a_character_with_numbered_arms_moves_each_as_the_config_moves_the_arm(tmp_path, character, clip):
    """AnimatedDrawings' six-armed char5 names its arms right_shoulder1, right_shoulder2, ...: a humanoid config
    drives each copy, which keeps its own drawn direction and turns as the arm does; the command says so."""
    import yaml

    cfg, _ = character
    data = yaml.safe_load(cfg.read_text())
    arm = ("right_shoulder", "right_elbow", "right_hand")
    rows = [{**r, "name": f"{r['name']}1" if r["name"] in arm else r["name"],
             "parent": f"{r['parent']}1" if r["parent"] in arm else r["parent"]} for r in data["skeleton"]]
    by_name = {r["name"]: r for r in rows}
    for n in arm:  # a second right arm, drawn 10 px lower and pointing 20 degrees further down
        first = by_name[f"{n}1"]
        rows.append({"name": f"{n}2", "parent": f"{first['parent'][:-1]}2" if first["parent"].endswith("1")
                     else first["parent"], "loc": [first["loc"][0], first["loc"][1] + 10]})
    c, s = np.cos(np.radians(20)), np.sin(np.radians(20))
    root = np.array(by_name["right_shoulder1"]["loc"], float) + [0, 10]
    for r in rows[-2:]:
        d = np.array(r["loc"], float) - root
        r["loc"] = [int(round(v)) for v in root + [c * d[0] - s * d[1], s * d[0] + c * d[1]]]
    cfg.write_text(yaml.safe_dump({**data, "skeleton": rows}))
    lines = []
    starting.new_from_animated_drawings(tmp_path / "six", cfg, clip[0], clip[1], say=lines.append)
    shot = json.loads((tmp_path / "six" / "shot.json").read_text())
    names = shot["skeleton"]["joints"]
    first, last = (np.array(shot["poses"][i]["joints"])[:, :2] for i in (0, -1))

    def turn(elbow, hand):
        a = [np.arctan2(*(p[names.index(hand)] - p[names.index(elbow)])[::-1]) for p in (first, last)]
        return (a[1] - a[0] + np.pi) % (2 * np.pi) - np.pi

    assert abs(turn("right_elbow1", "right_hand1")) > 0.3  # the clip lifts the forearm
    # the same turn, to the poses' written precision (a thousandth of a pixel over a forearm of some 20 px)
    assert turn("right_elbow2", "right_hand2") == pytest.approx(turn("right_elbow1", "right_hand1"), abs=1e-4)
    assert any("right_hand drives its numbered copies right_hand1, right_hand2" in x for x in lines)


def test_animated_drawings_character_without_a_clip_is_its_drawing(tmp_path, character):
    cfg, locs = character
    starting.new_from_animated_drawings(tmp_path / "ad", cfg, say=QUIET)
    data = json.loads((tmp_path / "ad" / "shot.json").read_text())
    check_v2(data, tmp_path / "ad")
    assert len(data["poses"]) == 1 and np.allclose(np.array(data["poses"][0]["joints"])[:, :2], locs)


def test_a_clip_that_leaves_the_texture_grows_the_canvas(tmp_path, character):
    """AnimatedDrawings' textures are cropped close to the character; a clip that carries it off them grows the
    canvas on those sides: the drawing's pixels and its mask move there unchanged, the poses with them, and the
    drawing's outline carried with its bones stays inside at every frame. --keep-canvas keeps the texture."""
    cfg, locs = character
    tex = cv2.imread(str(cfg.parent / "texture.png"), cv2.IMREAD_UNCHANGED)
    mask = cv2.imread(str(cfg.parent / "mask.png"), cv2.IMREAD_GRAYSCALE)
    rows, cols = np.flatnonzero(mask.any(1)), np.flatnonzero(mask.any(0))
    y0, x0 = rows[0], cols[0]  # crop to the character, as AnimatedDrawings' examples are
    tight = tmp_path / "tight"
    tight.mkdir()
    cv2.imwrite(str(tight / "texture.png"), tex[y0:rows[-1] + 1, x0:cols[-1] + 1])
    cv2.imwrite(str(tight / "mask.png"), mask[y0:rows[-1] + 1, x0:cols[-1] + 1])
    import yaml

    data = yaml.safe_load(cfg.read_text())
    data["height"], data["width"] = int(rows[-1] + 1 - y0), int(cols[-1] + 1 - x0)
    for r in data["skeleton"]:
        r["loc"] = [r["loc"][0] - int(x0), r["loc"][1] - int(y0)]
    (tight / "char_cfg.yaml").write_text(yaml.safe_dump(data))
    bvh, retarget = tmp_path / "hop.bvh", tmp_path / "retarget.yaml"
    retarget.write_text(RETARGET)
    bvh.write_text(bvh_text(swing(10), root_xyz=[(-1.5 * f, 18.0 + 0.5 * f, 0.0) for f in range(10)]))

    lines = []
    starting.new_from_animated_drawings(tmp_path / "grown", tight / "char_cfg.yaml", bvh, retarget, say=lines.append)
    starting.new_from_animated_drawings(tmp_path / "kept", tight / "char_cfg.yaml", bvh, retarget, say=QUIET,
                                        keep_canvas=True)
    grown = json.loads((tmp_path / "grown" / "shot.json").read_text())
    kept = json.loads((tmp_path / "kept" / "shot.json").read_text())
    check_v2(grown, tmp_path / "grown")
    key = cv2.imread(str(tmp_path / "grown" / "key0.png"), cv2.IMREAD_UNCHANGED)
    fg = cv2.imread(str(tmp_path / "grown" / "key0_fg.png"), cv2.IMREAD_GRAYSCALE)
    h, w = data["height"], data["width"]
    assert key.shape[0] > h or key.shape[1] > w
    assert any(x.startswith("canvas: ") for x in lines)
    shift = np.subtract(grown["poses"][0]["joints"], kept["poses"][0]["joints"])[:, :2]
    left, top = (int(round(v)) for v in shift[0])
    assert left > 0 and np.allclose(shift, [left, top], atol=1e-6)  # one shift for every joint of every frame
    np.testing.assert_allclose(np.subtract(grown["poses"][-1]["joints"], kept["poses"][-1]["joints"])[:, :2], shift)
    np.testing.assert_array_equal(key[top:top + h, left:left + w], cv2.imread(str(tight / "texture.png"),
                                                                              cv2.IMREAD_UNCHANGED))
    assert (fg[top:top + h, left:left + w] > 127).sum() == (mask > 127).sum() and (fg > 127).sum() == (mask > 127).sum()
    from ops.motion.canvas import carried_with_bones, outline_points
    from ops.types import Skeleton

    sk = Skeleton(HUMANOID.joints, np.asarray(HUMANOID.parents))
    poses = np.array([p["joints"] for p in grown["poses"]], float)
    reach = carried_with_bones(outline_points(fg > 127), poses[0], poses, sk)
    assert reach.min() >= 0 and reach[..., 0].max() <= key.shape[1] - 1 and reach[..., 1].max() <= key.shape[0] - 1
    kept_key = cv2.imread(str(tmp_path / "kept" / "key0.png"), cv2.IMREAD_UNCHANGED)
    assert kept_key.shape[:2] == (h, w)
    # a shot that exists keeps its canvas: `motion` says where the clip takes the character off it
    starting.new_from_animated_drawings(tmp_path / "still", tight / "char_cfg.yaml", say=QUIET)
    said = []
    starting.motion_from_bvh(tmp_path / "still", bvh, retarget, say=said.append)
    assert any("off the canvas" in x and "fix:" in x for x in said), said
    calm = []
    starting.motion_from_bvh(tmp_path / "grown", bvh, retarget, say=calm.append)  # the grown canvas holds it
    assert not any("off the canvas" in x for x in calm), calm


DOLL_RETARGET = RETARGET
for ad, doll in [("right_shoulder", "r_shoulder"), ("left_shoulder", "l_shoulder"), ("right_elbow", "r_elbow"),
                 ("left_elbow", "l_elbow"), ("right_hand", "r_hand"), ("left_hand", "l_hand"), ("right_hip", "r_hip"),
                 ("left_hip", "l_hip"), ("right_knee", "r_knee"), ("left_knee", "l_knee"), ("right_foot", "r_foot"),
                 ("left_foot", "l_foot"), ("torso", "neck"), ("neck", "head"), (" hip,", " pelvis,")]:
    DOLL_RETARGET = DOLL_RETARGET.replace(ad, doll)
DOLL_RETARGET = DOLL_RETARGET.replace("  head: !!python/tuple [Hips, Head]", "  head: !!python/tuple [Spine, Head]")
DOLL_RETARGET = DOLL_RETARGET.replace("- [above, head, r_shoulder, l_shoulder]", "- [above, head, r_shoulder, l_shoulder]")


def test_a_bvh_clip_drives_a_v1_sample_and_keeps_both_key_poses(tmp_path):
    shot = tmp_path / "two_poses"
    shutil.copytree(SAMPLES / "two_poses", shot)
    old = json.loads((shot / "shot.json").read_text())
    bvh, cfg = tmp_path / "clip.bvh", tmp_path / "doll.yaml"
    bvh.write_text(bvh_text(swing(14)))
    cfg.write_text(DOLL_RETARGET)
    lines = []
    starting.motion_from_bvh(shot, bvh, cfg, say=lines.append)
    data = json.loads((shot / "shot.json").read_text())
    check_v2(data, shot)
    assert data["key_frames"] == [0, 8] and len(data["poses"]) == 9  # v1's frames = 9, the clip cut after key 1
    assert data["poses"][0]["joints"] == old["poses"][0]["joints"]
    assert data["poses"][8]["joints"] == old["poses"][1]["joints"]
    assert (shot / "shot.json.bak").read_bytes() != (shot / "shot.json").read_bytes()
    assert any("left out" in x for x in lines)


def test_a_video_drives_a_sample_shot(tmp_path):
    shot = tmp_path / "no_occlusion"
    shutil.copytree(SAMPLES / "no_occlusion", shot)
    F = 12
    t = np.linspace(0, 0.6, F)
    sh, el = np.array([60.0, 50.0]), np.array([60.0, 80.0])
    hand = el + 28 * np.stack([np.sin(t), np.cos(t)], 1)  # the forearm swings out
    video = tmp_path / "clip.mp4"
    write_video(video, {"r_shoulder": np.repeat(sh[None], F, 0), "r_elbow": np.repeat(el[None], F, 0), "r_hand": hand})
    points = tmp_path / "points.json"
    points.write_text(json.dumps({"r_shoulder": sh.tolist(), "r_elbow": el.tolist(), "r_hand": hand[0].tolist()}))
    starting.motion_from_video(shot, video, points, say=QUIET)
    data = json.loads((shot / "shot.json").read_text())
    check_v2(data, shot)
    assert len(data["poses"]) == 9  # the v1 shot's two keys at frames 0 and 8 (9 poses, frames absent)


def one_error_line(capfd, argv) -> str:
    assert main(argv) == 2
    err = [x for x in capfd.readouterr().err.splitlines() if x.strip()]
    assert len(err) == 1 and err[0].startswith("error: ") and "fix:" in err[0], err
    return err[0]


def test_bad_inputs_are_one_line_each(tmp_path, capfd, character):
    shot = tmp_path / "s"
    shutil.copytree(SAMPLES / "no_occlusion", shot)
    bvh = tmp_path / "clip.bvh"
    bvh.write_text(bvh_text(swing(3), actor=[a for a in ACTOR if a[0] != "RightHand"]))
    cfg = tmp_path / "ad.yaml"
    cfg.write_text(RETARGET)
    assert "'RightHand'" in one_error_line(capfd, ["motion", str(shot), "--bvh", str(bvh), "--retarget", str(cfg)])
    bvh.write_text(bvh_text(swing(3)))
    assert "lacks" in one_error_line(capfd, ["motion", str(shot), "--bvh", str(bvh), "--retarget", str(cfg)])
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((64, 64, 3), 240, np.uint8))
    assert "blank" in one_error_line(capfd, ["new", str(tmp_path / "n"), str(blank)])
    noise = tmp_path / "noise.png"
    cv2.imwrite(str(noise), np.random.default_rng(0).integers(0, 255, (64, 64, 3)).astype(np.uint8))
    assert "not a drawing" in one_error_line(capfd, ["new", str(tmp_path / "n"), str(noise)])
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"\x00not a video" * 50)
    pts = tmp_path / "p.json"
    pts.write_text(json.dumps({"r_hand": [10, 10]}))
    assert "decoded" in one_error_line(capfd, ["motion", str(shot), "--video", str(junk), "--points", str(pts)])
    video = tmp_path / "v.mp4"
    write_video(video, {"r_hand": np.full((9, 2), 40.0)})
    pts.write_text(json.dumps({"r_hand": [999, 10]}))
    assert "outside" in one_error_line(capfd, ["motion", str(shot), "--video", str(video), "--points", str(pts)])
    assert "exactly one" in one_error_line(capfd, ["motion", str(shot)])
    cfg_path = str(character[0])
    assert "--keep-canvas" in one_error_line(capfd, ["new", str(tmp_path / "k"), "--animated-drawings", cfg_path,
                                                     "--keep-canvas"])
    assert "--keep-canvas" in one_error_line(capfd, ["new", str(tmp_path / "k"), str(blank), "--keep-canvas"])
    assert not (tmp_path / "k").exists()
    assert json.loads((shot / "shot.json").read_text())["format"] == "inbetween-shot/1"  # untouched throughout
