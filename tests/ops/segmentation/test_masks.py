"""Foreground and occlusion masks on synthetic ink drawings with known answers."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from ops.errors import ShotError
from ops.geometry.snap import snap_into
from ops.segmentation.bones import bone_radii, bone_regions, joined_bones, segment_distance, thick_regions
from ops.segmentation.foreground import segment_foreground
from ops.segmentation.masks import build_masks
from ops.segmentation.occlusion import predict_occlusion
from ops.types import Skeleton

PAPER = np.array([0.97, 0.95, 0.90], np.float32)  # faintly tinted paper


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two (H, W) bool masks."""
    return float((a & b).sum() / max((a | b).sum(), 1))


def capsule(shape: tuple[int, int], a, b, r: float) -> np.ndarray:
    """(H, W) bool pixels within r of the segment a-b."""
    ys, xs = np.mgrid[0 : shape[0], 0 : shape[1]]
    p = np.stack([xs, ys], -1).astype(float)
    return segment_distance(p, np.asarray(a, float), np.asarray(b, float)) <= r


def outline(m: np.ndarray) -> np.ndarray:
    """(H, W) bool one-pixel inner outline of a mask."""
    return m & ~cv2.erode(m.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)


def drawn(drawing: np.ndarray, pose: np.ndarray | None = None, skeleton: Skeleton | None = None) -> np.ndarray:
    """(H, W) bool drawn silhouette: pixels the segmented character covers at least half.

    Without a pose, one horizontal bone through the middle of the image (the ellipses below lie on it).
    """
    if pose is None:
        h, w = drawing.shape[:2]
        pose = np.array([[0.35 * w, 0.47 * h, 0], [0.65 * w, 0.47 * h, 0]])
        skeleton = Skeleton(("a", "b"), np.array([-1, 0]))
    return segment_foreground(drawing, pose, skeleton).coverage >= 0.5


def ink_drawing(ink: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32 drawing: dark ink on tinted paper with faint noise."""
    rng = np.random.default_rng(0)
    img = np.broadcast_to(PAPER, ink.shape + (3,)).copy()
    img += rng.normal(0, 0.01, img.shape).astype(np.float32)
    img[ink] = 0.12
    return np.clip(img, 0, 1)


def crossing_scene(size: int = 160):
    """A torso capsule with a bent arm whose forearm crosses in front of it.

    Returns (drawing, pose (5, 3), skeleton, true forearm-over-torso region, torso, forearm).
    Bones: 0 hips-neck (torso), 1 neck-shoulder (clavicle), 2 shoulder-elbow, 3 elbow-hand (forearm).
    """
    shape = (size, size)
    torso = capsule(shape, (80, 35), (80, 130), 22)
    upper = capsule(shape, (95, 45), (135, 70), 9)
    fore = capsule(shape, (135, 70), (40, 85), 9)
    arm = upper | fore
    drawing = ink_drawing((outline(torso) & ~arm) | outline(arm))  # the arm hides the torso's outline
    skeleton = Skeleton(("hips", "neck", "shoulder", "elbow", "hand"), np.array([-1, 0, 1, 2, 3]))
    pose = np.array([[80, 130, 0], [80, 35, 0], [95, 45, -1], [135, 70, -1], [40, 85, -1.0]])
    return drawing, pose, skeleton, torso & fore, torso, fore


def ellipse_mask(shape, center, axes) -> np.ndarray:
    """(H, W) bool filled ellipse."""
    m = np.zeros(shape, np.uint8)
    cv2.ellipse(m, center, axes, 0, 0, 360, 1, -1)
    return m > 0


@pytest.mark.parametrize("shade", [0.0, 0.2, 0.5])
def test_outlined_ellipse_becomes_filled_silhouette(shade: float):
    filled = ellipse_mask((128, 128), (64, 60), (40, 28))
    ring = filled & ~cv2.erode(filled.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    drawing = ink_drawing(ring)
    drawing *= 1.0 - shade * np.linspace(0, 1, 128, dtype=np.float32)[None, :, None]  # uneven lighting
    fg = drawn(drawing)
    assert iou(fg, filled) > 0.97


def test_gap_in_outline_closed_and_speck_dropped():
    filled = ellipse_mask((128, 128), (64, 64), (36, 30))
    ring = filled & ~cv2.erode(filled.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    ring[60:63, :] = False  # a 3-pixel gap on both sides of the outline
    ink = ring.copy()
    ink[5:8, 5:8] = True  # a speck of dirt far from the character
    fg = drawn(ink_drawing(ink))
    assert not fg[5:8, 5:8].any()
    assert iou(fg, filled) > 0.95


def test_alpha_is_composited_over_white():
    filled = ellipse_mask((96, 96), (48, 48), (30, 20))
    rgba = np.zeros((96, 96, 4), np.float32)  # black but fully transparent canvas
    ring = outline(filled)
    rgba[ring] = (0.1, 0.1, 0.1, 1.0)
    rgba[filled & ~ring] = (1.0, 1.0, 1.0, 1.0)
    fg = drawn(rgba)
    assert iou(fg, filled) > 0.95


def test_segment_distance_matches_brute_force():
    rng = np.random.default_rng(1)
    a, b = np.array([3.0, 4.0]), np.array([20.0, -7.0])
    p = rng.uniform(-20, 40, (200, 2))
    dense = a + np.linspace(0, 1, 20001)[:, None] * (b - a)
    brute = np.linalg.norm(p[:, None] - dense[None], axis=2).min(axis=1)
    np.testing.assert_allclose(segment_distance(p, a, b), brute, atol=2e-3)


def test_bone_radii_read_limb_thickness():
    drawing, pose, skeleton, _, _, _ = crossing_scene()
    fg = drawn(drawing, pose, skeleton)
    r = bone_radii(fg, pose, skeleton)
    assert abs(r[0] - 22) < 2.5  # torso
    assert abs(r[3] - 9) < 2.0  # forearm, despite lying half over the torso


def test_bone_regions_disjoint_and_thick_regions_overlap():
    drawing, pose, skeleton, true, _, _ = crossing_scene()
    fg = drawn(drawing, pose, skeleton)
    vor = bone_regions(fg, pose, skeleton)
    thick = thick_regions(fg, pose, skeleton)
    assert vor.sum(axis=0).max() <= 1  # Voronoi regions are disjoint
    assert not (vor & ~fg).any() and not (thick & ~fg).any()
    assert iou(thick[0] & thick[3], true) > 0.6  # torso and forearm bodies overlap where they cross


def test_predicted_crossing_puts_forearm_in_front():
    drawing, pose, skeleton, true, _, _ = crossing_scene()
    masks = build_masks(drawing, pose, skeleton, occlusion="skeleton")
    assert masks.source == "predicted"
    best = int(np.argmax([iou(r, true) for r in masks.occlusion]))
    assert iou(masks.occlusion[best], true) > 0.6
    assert 3 in masks.front_bones[best] and 0 not in masks.front_bones[best]
    for r in masks.occlusion:
        assert not (r & ~masks.foreground).any()


def test_merged_region_keeps_every_bone_mostly_in_front():
    """A forearm over the belly whose overlap touches the near shin's over the far shin: one region, and the near
    shin stays in front there (with the arm alone in front, the near leg went to the pocket and the drawn leg had
    no handle: flat_colour)."""
    shape = (200, 160)
    skeleton = Skeleton(("hips", "neck", "shoulder", "elbow", "hand", "rknee", "rfoot", "lknee", "lfoot"),
                        np.array([-1, 0, 1, 2, 3, 0, 5, 0, 7]))
    pose = np.array([[80, 110, 0], [80, 35, 0], [95, 45, -1], [130, 95, -1], [76, 140, -1],
                     [78, 150, -0.5], [78, 190, -0.5], [83, 150, 0.5], [83, 190, 0.5]])
    fg = np.zeros(shape, bool)
    for p, c in skeleton.bones:
        fg |= capsule(shape, pose[p, :2], pose[c, :2], 22 if c == 1 else 9)
    regions, fronts, _ = predict_occlusion(fg, pose, skeleton)
    merged = int(np.argmax([r.sum() for r in regions]))
    assert regions[merged][140:190].any() and regions[merged][60:110].any()  # belly and shins: one region
    # bones (child order): 3 elbow-hand, 5 rknee-rfoot (near shin) in front; torso 0 and far leg 6, 7 behind
    assert {3, 5} <= set(fronts[merged].tolist())
    assert not {0, 6, 7} & set(fronts[merged].tolist())


def test_adjacent_bones_produce_no_region():
    shape = (128, 128)
    upper = capsule(shape, (30, 40), (80, 60), 10)
    fore = capsule(shape, (80, 60), (40, 95), 10)  # bent back at the elbow: bodies overlap there
    drawing = ink_drawing(outline(upper | fore))
    skeleton = Skeleton(("shoulder", "elbow", "hand"), np.array([-1, 0, 1]))
    pose = np.array([[30, 40, 0], [80, 60, -1], [40, 95, -2.0]])
    masks = build_masks(drawing, pose, skeleton, occlusion="skeleton")  # the rule; the drawing's joint overlaps count
    assert masks.occlusion == [] and masks.front_bones == []


def test_bones_joined_through_a_bone_of_no_length_meet_as_at_a_joint():
    """AnimatedDrawings' root and hip share one location: the pelvis (root - knee here) and the spine (hip - neck)
    meet there as at a joint, so at equal depth their overlap is no warning. At different depths it stays a
    region (a side view's near hip over the body). With the hip 10 px off the root they are two parts."""
    shape = (160, 160)
    spine = capsule(shape, (80, 40), (80, 90), 14)
    thigh = capsule(shape, (80, 90), (60, 140), 10)
    drawing = ink_drawing(outline(spine | thigh))
    skeleton = Skeleton(("root", "hip", "neck", "knee"), np.array([-1, 0, 1, 0]))
    at = np.array([[80, 90], [80, 90], [80, 40], [60, 140]], float)
    flat = np.c_[at, np.zeros(4)]
    assert joined_bones(flat, skeleton)[1, 2]  # hip - neck and root - knee
    regions, _, warnings = predict_occlusion(drawn(drawing, flat, skeleton), flat, skeleton)
    assert regions == [] and not any("equal depth" in w for w in warnings), warnings
    deep = np.c_[at, [0.0, 0.0, 1.0, -1.0]]
    regions, fronts, _ = predict_occlusion(drawn(drawing, deep, skeleton), deep, skeleton)
    assert len(regions) == 1 and 2 in fronts[0]  # the thigh in front of the spine
    apart = np.array([[80, 100, 0.0], [80, 90, 0.0], [80, 40, -1.0], [60, 140, 1.0]])
    assert not joined_bones(apart, skeleton)[1, 2]
    # a side view: both hips project onto the root, and the thighs hanging from them stay two parts
    side = Skeleton(("root", "hip", "neck", "r_hip", "r_knee", "l_hip", "l_knee"), np.array([-1, 0, 1, 0, 3, 0, 5]))
    at = np.array([[80, 90], [80, 90], [80, 40], [80, 90], [60, 140], [80, 90], [100, 140]], float)
    joined = joined_bones(np.c_[at, np.zeros(7)], side)
    bone = {tuple(side.bones[i]): i for i in range(len(side.bones))}
    assert not joined[bone[(3, 4)], bone[(5, 6)]]  # right thigh, left thigh
    assert joined[bone[(1, 2)], bone[(0, 3)]]  # the spine and the pelvis' right half, through the root - hip bone


def test_equal_depths_predict_nothing_but_warn():
    drawing, pose, skeleton, _, _, _ = crossing_scene()
    flat = pose.copy()
    flat[:, 2] = 0.0
    regions, fronts, warnings = predict_occlusion(drawn(drawing, pose, skeleton), flat, skeleton)
    assert regions == [] and any("equal depth" in w for w in warnings)


def test_manual_foreground_overrides():
    drawing, pose, skeleton, _, _, _ = crossing_scene()
    manual = np.zeros(drawing.shape[:2], np.float32)
    manual[20:150, 30:150] = 1.0
    masks = build_masks(drawing, pose, skeleton, manual_foreground=manual)
    assert np.array_equal(masks.foreground, manual > 0.5)
    assert masks.source == "mixed"


def test_manual_occlusion_clipped_with_warning_and_front_bone():
    drawing, pose, skeleton, true, _, _ = crossing_scene()
    poking = true.copy()
    poking[60:95, 100:150] = True  # spills past the torso into the paper below the arm
    outside_only = np.zeros_like(true)
    outside_only[0:5, 0:5] = True  # entirely on the paper
    masks = build_masks(drawing, pose, skeleton, manual_occlusion=[poking, outside_only])
    assert len(masks.occlusion) == 1
    assert not (masks.occlusion[0] & ~masks.foreground).any()
    assert any("clipped" in w for w in masks.warnings)
    assert any("dropped" in w for w in masks.warnings)
    assert 3 in masks.front_bones[0] and 0 not in masks.front_bones[0]


def test_manual_regions_sorted_back_to_front():
    drawing, pose, skeleton, true, torso, fore = crossing_scene()
    fg = build_masks(drawing, pose, skeleton).foreground
    front = true  # covered by the forearm (z = -1)
    back = torso & ~fore & fg
    back[:, :] &= np.arange(back.shape[0])[:, None] > 110  # lower torso only (z = 0)
    masks = build_masks(drawing, pose, skeleton, manual_occlusion=[front, back])
    assert np.array_equal(masks.occlusion[0], back) and np.array_equal(masks.occlusion[1], front)
    # painted regions are the user's layers: where they overlap they stack (three local layers), after refining too
    assert masks.nest_groups == [0, 0]
    from ops.segmentation.refine import refine_masks

    assert refine_masks(masks, np.zeros((0, 2)), pose, skeleton).nest_groups == [0, 0]
    # predicted regions stack with none unless a crossing split them
    assert all(g == -1 for g in build_masks(drawing, pose, skeleton).nest_groups)


def test_manual_mask_of_wrong_size_is_a_shot_error():
    drawing, pose, skeleton, _, _, _ = crossing_scene()
    with pytest.raises(ShotError):
        build_masks(drawing, pose, skeleton, manual_foreground=np.ones((10, 10)))


def test_joint_slightly_outside_is_reported():
    drawing, pose, skeleton, _, _, _ = crossing_scene()
    moved = pose.copy()
    moved[4, 0] = 40 - 9 - 5  # hand tip 5 px beyond the forearm's round end, 3 px beyond the mask's rim
    masks = build_masks(drawing, moved, skeleton)
    assert any("hand" in w and "slightly outside" in w for w in masks.warnings)


def test_snap_into_matches_brute_force():
    mask = ellipse_mask((64, 64), (32, 30), (20, 12))
    pts = np.array([[32.0, 30.0], [55.0, 30.0], [32.0, 45.5], [0.0, 0.0], [70.0, 30.0]])
    out, moved = snap_into(mask, pts)
    inside = np.argwhere(mask)[:, ::-1].astype(float)  # (x, y)
    assert np.array_equal(moved, [False, True, True, True, True])
    assert np.array_equal(out[0], pts[0])
    for p, q in zip(pts[1:], out[1:]):
        best = np.linalg.norm(inside - np.clip(np.round(p), 0, 63), axis=1).min()
        assert mask[int(q[1]), int(q[0])]
        assert np.linalg.norm(q - np.clip(np.round(p), 0, 63)) == pytest.approx(best)


def test_bone_regions_and_thick_regions_match_brute_force():
    drawing, pose, skeleton, _, _, _ = crossing_scene(128)
    fg = drawn(drawing, pose, skeleton)
    ys, xs = np.mgrid[0:128, 0:128]
    grid = np.stack([xs, ys], -1).astype(float)
    ends = pose[:, :2][skeleton.bones]
    dist = np.stack([segment_distance(grid, a, b) for a, b in ends])  # (B, H, W) full-image fast path
    r = bone_radii(fg, pose, skeleton)
    thick_bf = (dist <= r[:, None, None] + 1.5) & fg
    near = np.argmin(dist, axis=0)
    vor_bf = (near == np.arange(len(r))[:, None, None]) & (dist <= 1.6 * r[:, None, None]) & fg
    assert np.array_equal(thick_regions(fg, pose, skeleton), thick_bf)
    assert np.array_equal(bone_regions(fg, pose, skeleton), vor_bf)


def test_solid_ink_fill_is_foreground():
    filled = ellipse_mask((128, 128), (64, 60), (40, 28))
    assert iou(drawn(ink_drawing(filled)), filled) > 0.97


def test_opaque_rgba_drawing_uses_the_ink_not_the_alpha():
    filled = ellipse_mask((128, 128), (64, 60), (40, 28))
    rgba = np.concatenate([ink_drawing(outline(filled)), np.ones((128, 128, 1), np.float32)], axis=2)
    assert iou(drawn(rgba), filled) > 0.97
