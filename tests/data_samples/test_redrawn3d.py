"""The held-out redrawn set (redrawn3d.py): a 128 px shot of each kind keeps its promises, the same call draws the
same bytes, amount 0 is today's rigid shot, and heldout_shots.py --set redrawn writes loadable shots."""
from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest
from scipy import ndimage

from benchmarks.heldout_shots import check_shot, main
from data_samples.generator import redrawn3d as rd
from data_samples.generator.bodies3d import make_body
from data_samples.generator.looks3d import make_look3d
from data_samples.generator.occlusion3d import sample_seed
from data_samples.generator.render3d import make_camera, render
from data_samples.generator.shots3d import (
    REDRAW_IOU,
    SHOT_FRAMES,
    SHOT_INDEX_BASE,
    STREAM,
    _on_camera,
    make_shot3d,
    place,
    procedural_motion,
    write_shot3d,
    write_true_annotation,
)
from ops.shotio.load import load_shot

SIZE = (128, 128)
SCALE = SIZE[0] * SIZE[1] / 256.0 ** 2
ENTRIES = {"side_walk": 0, "arm_over_belly": 3, "fold_arms": 5}  # thin, round (both with a rigid twin), thin


@pytest.fixture(scope="module")
def shots():
    return {kind: rd.make_redrawn3d(e, SIZE) for kind, e in ENTRIES.items()}


def _joint(shot, name: str, k: int) -> np.ndarray:
    return shot.poses[k, shot.joints.index(name)]


def test_the_plan_covers_every_kind_style_and_a_held_out_family():
    plan = rd.REDRAWN_PLAN
    assert {k for _, _, k, _ in plan} == set(rd.KINDS)
    assert {s for _, s, _, _ in plan} >= {"ink", "flat", "watercolour", "pencil", "no_outline", "crayon"}
    assert any(f == "creature" or s == "crayon" for f, s, _, _ in plan)
    amounts = [a for *_, am in plan for a in am]
    assert 8 <= len(amounts) <= 12 and 1 <= amounts.count(0.0) <= 2 and all(f in rd.FAMILIES[k] for f, _, k, _ in plan)


def test_side_walk_legs_overlap_at_the_keys_and_part_between(shots):
    """Recorded: the legs overlap below the knees at both keys, the near leg in front, and part at mid-step.
    Independently, from the skeleton: the near leg is nearer the camera, its knee bent at key0 and the far leg's
    at key1 (the passing legs), the other one about straight."""
    walk, rigid = shots["side_walk"]
    for shot in (walk, rigid):
        c = shot.extra["checks"]
        px = c["leg_overlap_px"]
        assert min(px[0], px[-1]) >= rd.LEG_OVERLAP_PX * SCALE and px[len(px) // 2] <= rd.LEG_APART * min(px[0], px[-1])
        assert min(c["near_leg_front"]) >= rd.FRONT
    near = walk.extra["near_side"]
    far = "left" if near == "right" else "right"

    def knee(side, k):
        hip, kn, foot = (_joint(walk, f"{side}_{n}", k) for n in ("hip", "knee", "foot"))
        a, b = kn - hip, foot - kn
        return math.degrees(math.acos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))

    assert knee(near, 0) > knee(far, 0) + 25 and knee(far, -1) > knee(near, -1) + 25
    for k in (0, -1):
        assert _joint(walk, f"{near}_knee", k)[2] < _joint(walk, f"{far}_knee", k)[2]


def test_an_arm_lies_over_the_belly_at_one_key_only(shots):
    """Recorded: the forearm over the torso at its key (in front), off it at the other. Independently: at that
    key the hand is in front of the torso's axis."""
    for shot in shots["arm_over_belly"]:
        c = shot.extra["checks"]
        k = -1 if shot.extra["over_key"] else 0  # the key the arm lies over the belly at
        on, off = c["forearm_on_belly_px"][k], c["forearm_on_belly_px"][-1 - k]
        assert on >= rd.ARM_OVER_PX * SCALE and off <= rd.ARM_OFF * on and c["forearm_front"] >= rd.FRONT
        assert _joint(shot, f"{shot.extra['near_side']}_hand", k)[2] < _joint(shot, "torso", k)[2]


def test_folded_arms_cross_in_three_depths_and_unfold(shots):
    """Recorded: torso and both forearms meet in one region, in that depth order. Independently, in the
    skeleton (x, y, depth: an orthographic view, so across the body is the shoulders' direction): at the folded
    key each hand is past the middle of the chest, on the other arm's side, and at the unfolded key on its own."""
    (shot,) = shots["fold_arms"]
    c = shot.extra["checks"]
    assert c["three_depths_px"] >= rd.FOLD_PX * SCALE and c["depth_order_share"] >= rd.FRONT
    assert c["unfolded_overlap_px"] <= rd.FOLD_APART_PX * SCALE
    fold = -1 if shot.extra["fold_key"] else 0
    for k, across in ((fold, True), (-1 - fold, False)):
        mid = _joint(shot, "torso", k)
        left = _joint(shot, "left_shoulder", k) - _joint(shot, "right_shoulder", k)
        for side, own in (("left", 1), ("right", -1)):
            assert (np.sign((_joint(shot, f"{side}_hand", k) - mid) @ left) == -own) == across, (side, k)


def test_redrawn_keys_differ_by_the_amount_and_the_twin_is_rigid(shots):
    """A redrawn key1 is further from key0's shapes reposed to it than REDRAW_IOU * amount; less redrawn,
    nearer; the rigid twin's key0 differs from the redrawn key0 (the same body drawn anew)."""
    walk, rigid = shots["side_walk"]
    assert walk.extra["redraw"] == 1.0 and rigid.extra["redraw"] == 0.0 and "redraw_iou" not in rigid.extra["checks"]
    assert walk.extra["checks"]["redraw_iou"] <= 1 - REDRAW_IOU
    assert walk.extra["twins"] == [rigid.name] and rigid.name.endswith("_rigid") and walk.name.endswith("_redrawn")
    assert np.array_equal(walk.poses, rigid.poses) and not np.array_equal(walk.frames[0], rigid.frames[0])
    (half,) = rd.make_redrawn3d(ENTRIES["side_walk"], SIZE, amounts=(0.5,))
    if half.attempt == walk.attempt:  # the same body, camera and motion: a smaller change
        assert walk.extra["checks"]["redraw_iou"] < half.extra["checks"]["redraw_iou"] <= 1 - REDRAW_IOU * 0.5


def test_the_same_call_draws_the_same_shot(shots, tmp_path):
    walk = shots["side_walk"][0]
    (again, _) = rd.make_redrawn3d(ENTRIES["side_walk"], SIZE)
    assert np.array_equal(walk.frames, again.frames) and np.array_equal(walk.poses, again.poses)
    a, b = write_shot3d(walk, tmp_path / "a"), write_shot3d(again, tmp_path / "b")
    for f in sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file()):
        assert (a / f).read_bytes() == (b / f).read_bytes(), f


def test_a_rigid_twin_is_the_shot_drawn_alone_at_amount_nought(shots):
    (alone,) = rd.make_redrawn3d(ENTRIES["arm_over_belly"], SIZE, amounts=(0.0,))
    twin = shots["arm_over_belly"][1]
    assert alone.attempt == twin.attempt and np.array_equal(alone.frames, twin.frames)


def test_amount_nought_is_todays_rigid_shot():
    """make_shot3d at redraw 0 draws, byte for byte, what the rigid path draws without any redrawing: the body
    posed by procedural_motion and rendered with the look's own hand."""
    index = 2
    shot = make_shot3d(index, SIZE, redraw=0.0)
    seed = sample_seed("test", SHOT_INDEX_BASE + index)
    rng = np.random.default_rng([seed, shot.attempt, STREAM])
    bodies, _ = procedural_motion(make_body(rng, shot.family), shot.motion, rng, np.linspace(0, 1, SHOT_FRAMES))
    camera = make_camera(rng)
    project = place(bodies, camera, SIZE, rng)
    look = make_look3d(shot.style, rng, scale=max(SIZE) / 256.0)
    for k, body in enumerate(bodies):
        assert np.array_equal(render(*_on_camera(body, project), SIZE, look, seed * 7 + shot.attempt).rgb, shot.frames[k])
    redrawn = make_shot3d(index, SIZE, redraw=1.0)
    assert redrawn.extra["redraw_iou"] <= 1 - REDRAW_IOU and not np.array_equal(redrawn.frames, shot.frames)


def test_heldout_shots_writes_the_redrawn_set(tmp_path):
    assert main([str(tmp_path), "--set", "redrawn", "--count", "1", "--size", "128"]) == 0
    dirs = sorted(d for d in tmp_path.iterdir() if d.name.startswith("r"))
    assert [d.name for d in dirs] == ["r00_thin_ink_side_walk_redrawn", "r01_thin_ink_side_walk_rigid"]
    for d in dirs:
        check_shot(d)
        meta = json.loads((d / "heldout.json").read_text())
        assert {"kind", "redraw", "style", "family", "checks", "twins"} <= set(meta) and meta["set"] == "redrawn"
    manifest = json.loads((tmp_path / "previews" / "manifest.json").read_text())
    assert [m["shot"] for m in manifest] == [d.name for d in dirs]
    assert (tmp_path / "previews" / f"{dirs[0].name}.png").is_file()


def test_the_true_annotation_paints_every_recorded_crossing_with_its_junctions(shots, tmp_path):
    """write_true_annotation: the loader reads one painted region per pair of overlapping bones that share no joint;
    every crossing the generator recorded (>= MIN_EVIDENCE_PX) is one of them, each region lies where both bones'
    shapes do inside the character, and its T-junctions lie on the front bone's shape's edge."""
    folded = shots["fold_arms"][0]
    d = write_shot3d(folded, tmp_path)
    described = write_true_annotation(folded, d)
    loaded = load_shot(d)
    for k, (cover, _) in enumerate(folded.key_parts):
        regions = described[k]
        assert len(loaded.occlusion_masks[k]) == len(regions) > 0
        names = {f"{r['front_part']}/{r['back_part']}" for r in regions}
        assert set(folded.crossings[k]) <= names
        bone = {f"{folded.joints[folded.parents[c]]}-{folded.joints[c]}": i
                for i, c in enumerate(c for c in range(len(folded.parents)) if folded.parents[c] >= 0)}
        for r, path in zip(regions, loaded.occlusion_masks[k]):
            mask = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE) > 127
            front, back = cover[bone[r["front_part"]]], cover[bone[r["back_part"]]]
            assert mask.sum() == r["pixels"] and not (mask & ~(front & back)).any()
        points = np.array([p for r in regions for p in r["t_junctions"]]).reshape(-1, 2)
        assert len(loaded.t_junctions[k]) == len(points)
        if len(points):
            front_any = np.any([cover[bone[r["front_part"]]] for r in regions], axis=0)
            edge = front_any ^ ndimage.binary_erosion(front_any)
            dist = ndimage.distance_transform_edt(~edge)
            ij = np.clip(np.round(points[:, ::-1]).astype(int), 0, np.array(edge.shape) - 1)
            assert dist[ij[:, 0], ij[:, 1]].max() <= 2.0
