"""One region per overlapping bone pair; the front read off the drawing (whose outline runs through), z elsewhere."""
from __future__ import annotations

import warnings

import numpy as np

from ops.segmentation.bones import bone_radii
from ops.segmentation.occlusion_pairs import (
    bone_pairs,
    contrast_map,
    outline_contrast,
    pair_components,
    pair_regions,
    read_front,
)
from ops.types import Skeleton
from tests.ops.segmentation.test_masks import capsule, crossing_scene, ink_drawing, outline

FOREARM, TORSO = 3, 0


def scene(size: int = 256):
    """crossing_scene drawn at 256 px (outlines long enough to read): drawing, pose, skeleton, truth, fg, radii."""
    s = size / 160
    shape = (size, size)
    torso = capsule(shape, (80 * s, 35 * s), (80 * s, 130 * s), 22 * s)
    upper = capsule(shape, (95 * s, 45 * s), (135 * s, 70 * s), 9 * s)
    fore = capsule(shape, (135 * s, 70 * s), (40 * s, 85 * s), 9 * s)
    arm = upper | fore
    pose = np.array([[80, 130, 0], [80, 35, 0], [95, 45, -1], [135, 70, -1], [40, 85, -1.0]])
    pose[:, :2] *= s
    skeleton = Skeleton(("hips", "neck", "shoulder", "elbow", "hand"), np.array([-1, 0, 1, 2, 3]))
    fg = torso | arm
    return pose, skeleton, torso & fore, fg, torso, arm


def test_contrast_reads_a_unit_step_as_about_one():
    img = np.zeros((20, 20, 3), np.float32)
    img[:, 10:] = 1.0
    c = contrast_map(img)
    assert abs(c[10, 9] - 1.0) < 0.3 and c[10, 3] == 0.0
    assert outline_contrast(img)[10, 7] == c.max()  # carried within a stroke's reach


def test_pairs_are_the_two_nearest_bodies():
    _, pose, skeleton, true, fg, _ = crossing_scene()
    radii = bone_radii(fg, pose, skeleton)
    pairs = bone_pairs(true, pose, skeleton, radii)
    ys, xs = np.nonzero(true)
    got = pairs[ys, xs]
    assert (np.all(got == [TORSO, FOREARM], axis=1)).mean() > 0.9
    assert (pairs[~true] == -1).all()


def test_one_region_per_pair():
    """The forearm's overlap with the torso and an overlap of the upper arm with the torso, touching: two pairs,
    two regions, each with its own pixels."""
    _, pose, skeleton, true, fg, _ = crossing_scene()
    radii = bone_radii(fg, pose, skeleton)
    upper = capsule(fg.shape, (95, 45), (135, 70), 9) & capsule(fg.shape, (80, 35), (80, 130), 22)
    parts = pair_components(true | upper, pose, skeleton, radii)
    keys = sorted((a, b) for a, b, _ in parts)
    assert (TORSO, FOREARM) in keys and len(keys) == len(set(keys))
    total = np.zeros_like(fg, dtype=int)
    for _, _, r in parts:
        total += r
    assert total.max() == 1  # disjoint


def test_the_drawing_puts_the_bone_whose_outline_runs_through_in_front():
    pose, skeleton, true, fg, torso, arm = scene()
    radii = bone_radii(fg, pose, skeleton)
    front_drawn = ink_drawing((outline(torso) & ~arm) | outline(arm))  # the arm hides the torso's outline
    back_drawn = ink_drawing(outline(torso) | (outline(arm) & ~torso))  # the torso hides the forearm
    for drawing, front in ((front_drawn, FOREARM), (back_drawn, TORSO)):
        reading = read_front(true, TORSO, FOREARM, outline_contrast(drawing), fg, pose, skeleton, radii)
        assert reading.front == front, reading


def test_a_thin_region_reads_without_a_nan():
    """A region over 40 px whose 2 px erosion is empty (a 3 px strip across the crossing) has no inside contrast to
    compare with: a NaN there read no bone as drawn, and numpy warned on the run's terminal (r02's key0)."""
    pose, skeleton, true, fg, torso, arm = scene()
    radii = bone_radii(fg, pose, skeleton)
    cx = int(np.median(np.nonzero(true)[1]))
    strip = true.copy()
    strip[:, :cx - 1] = strip[:, cx + 2:] = False
    assert strip.sum() > 40
    front_drawn = ink_drawing((outline(torso) & ~arm) | outline(arm))
    back_drawn = ink_drawing(outline(torso) | (outline(arm) & ~torso))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = [read_front(strip, TORSO, FOREARM, outline_contrast(d), fg, pose, skeleton, radii)
               for d in (front_drawn, back_drawn)]
    assert all(np.isfinite(list(r.contrast.values())).all() for r in got)
    assert got[0].front != TORSO and got[1].front != FOREARM


def test_the_drawing_overrides_z_with_one_warning_naming_both_bones():
    pose, skeleton, true, fg, torso, arm = scene()
    radii = bone_radii(fg, pose, skeleton)
    drawing = ink_drawing((outline(torso) & ~arm) | outline(arm))
    wrong = pose.copy()
    wrong[2:, 2] = 1.0  # z says the arm is behind the torso
    regions, fronts, warnings = pair_regions(true, drawing, fg, wrong, skeleton, radii, source="key0.png")
    assert len(regions) == 1 and fronts[0].tolist() == [FOREARM]
    assert len(warnings) == 1
    w = warnings[0]
    assert w.startswith("key0.png") and "elbow-hand" in w and "hips-neck" in w and "fix:" in w
    assert w.index("shows elbow-hand in front") < w.index("z says hips-neck")
    # z agrees: no warning
    assert pair_regions(true, drawing, fg, pose, skeleton, radii)[2] == []


def test_a_flat_silhouette_leaves_the_front_to_z():
    pose, skeleton, true, fg, _, _ = scene()
    radii = bone_radii(fg, pose, skeleton)
    flat = np.ones(fg.shape + (3,), np.float32)
    flat[fg] = (0.3, 0.5, 0.8)  # one flat colour: nothing shows where the arm crosses
    assert read_front(true, TORSO, FOREARM, outline_contrast(flat), fg, pose, skeleton, radii).front == -1
    for z_arm, front in ((-1.0, FOREARM), (1.0, TORSO)):
        p = pose.copy()
        p[2:, 2] = z_arm
        regions, fronts, warnings = pair_regions(true, flat, fg, p, skeleton, radii)
        assert fronts[0].tolist() == [front] and warnings == []


def test_equal_depths_and_no_evidence_warn():
    pose, skeleton, true, fg, _, _ = scene()
    radii = bone_radii(fg, pose, skeleton)
    p = pose.copy()
    p[:, 2] = 0.0
    _, fronts, warnings = pair_regions(true, None, fg, p, skeleton, radii)
    assert len(fronts) == 1 and len(warnings) == 1 and "equal depths" in warnings[0]


def test_the_hybrid_regions_fronts_follow_the_drawing():
    """check_fronts: the skeleton rule's region over the crossing, its front taken from a wrong z (the torso), is
    turned to the forearm the drawing shows in front, with the warning; a right z is left alone, silently."""
    from ops.segmentation.occlusion import predict_occlusion
    from ops.segmentation.occlusion_pairs import check_fronts

    pose, skeleton, true, fg, torso, arm = scene()
    drawing = ink_drawing((outline(torso) & ~arm) | outline(arm))
    wrong = pose.copy()
    wrong[2:, 2] = 1.0
    regions, fronts, _ = predict_occlusion(fg, wrong, skeleton)
    crossing = max(range(len(regions)), key=lambda i: (regions[i] & true).sum())
    assert FOREARM not in fronts[crossing]
    checked, warnings = check_fronts(regions, fronts, drawing, fg, wrong, skeleton, "key1.png")
    assert FOREARM in checked[crossing] and TORSO not in checked[crossing]
    assert len(warnings) == 1 and "elbow-hand" in warnings[0] and "hips-neck" in warnings[0]
    regions, fronts, _ = predict_occlusion(fg, pose, skeleton)
    checked, warnings = check_fronts(regions, fronts, drawing, fg, pose, skeleton)
    assert warnings == [] and all(np.array_equal(a, b) for a, b in zip(checked, fronts))


def test_split_by_pairs_gives_each_overlapping_bone_pair_its_own_region_and_front():
    """`--occlusion pairs`: one region over two forearms crossing the torso (as the skeleton rule joins touching
    overlaps into one) comes back as two disjoint regions inside it, one per bone pair, each with its own forearm
    in front as the drawing shows."""
    from ops.segmentation.occlusion_drawing import split_by_pairs

    shape = (256, 256)
    torso = capsule(shape, (128, 50), (128, 210), 34)
    arm1 = capsule(shape, (150, 70), (210, 100), 12) | capsule(shape, (210, 100), (60, 120), 12)
    arm2 = capsule(shape, (106, 70), (46, 160), 12) | capsule(shape, (46, 160), (200, 180), 12)
    pose = np.array([[128, 210, 0], [128, 50, 0], [150, 70, -1], [210, 100, -1], [60, 120, -1],
                     [106, 70, -1], [46, 160, -1], [200, 180, -1.0]])
    skeleton = Skeleton(("hips", "neck", "r_shoulder", "r_elbow", "r_hand", "l_shoulder", "l_elbow", "l_hand"),
                        np.array([-1, 0, 1, 2, 3, 1, 5, 6]))
    fg = torso | arm1 | arm2
    fore1, fore2 = capsule(shape, (210, 100), (60, 120), 12), capsule(shape, (46, 160), (200, 180), 12)
    joined = torso & (fore1 | fore2)
    drawing = ink_drawing((outline(torso) & ~(arm1 | arm2)) | outline(arm1) | outline(arm2))
    regions, fronts, _ = split_by_pairs([joined], drawing, fg, pose, skeleton)
    assert len(regions) == 2 and len(fronts) == 2
    assert (np.sum(regions, axis=0) <= 1).all() and not (np.any(regions, axis=0) & ~joined).any()
    for fore, hand in ((fore1, 4), (fore2, 7)):
        r = max(range(2), key=lambda i: (regions[i] & fore).sum())
        assert (regions[r] & fore & torso).sum() > 0.8 * (fore & torso).sum()
        assert fronts[r].tolist() == [hand - 1]  # the forearm's bone (elbow -> hand), by its child joint - 1
    assert split_by_pairs([], drawing, fg, pose, skeleton) == ([], [], [])
