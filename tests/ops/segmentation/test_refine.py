"""Occlusion-mask refinement by T-junctions: polylines, junction snapping, deformation."""
from __future__ import annotations

import cv2
import numpy as np

from ops.geometry.polygon import polygon_area
from ops.segmentation.junctions import assign_junctions, merge_clicks
from ops.segmentation.masks import build_masks
from ops.segmentation.refine import mask_boundary, rasterize, refine_masks, refine_region, simplify
from ops.types import Skeleton
from tests.ops.segmentation.test_masks import crossing_scene, ellipse_mask, iou

STICK = Skeleton(joints=("a", "b"), parents=np.array([-1, 0]))


def point_to_polyline(Q: np.ndarray, P: np.ndarray) -> np.ndarray:
    """(k,) distance, pixels, from points Q (k, 2) to the closed polyline P (n, 2)."""
    a, b = P, np.roll(P, -1, axis=0)
    e = b - a
    s = np.clip(((Q[:, None] - a[None]) * e[None]).sum(-1) / np.maximum((e**2).sum(1), 1e-12), 0, 1)
    return np.linalg.norm(Q[:, None] - (a[None] + s[..., None] * e[None]), axis=2).min(axis=1)


def raw_contour(mask: np.ndarray) -> np.ndarray:
    """(n, 2) float64 unsimplified outer contour of a mask's largest component."""
    cs, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    return max(cs, key=len).reshape(-1, 2).astype(np.float64)


def blob() -> np.ndarray:
    """(96, 96) bool region with curved and straight parts (ellipse union rectangle)."""
    m = ellipse_mask((96, 96), (40, 48), (26, 18))
    m[40:60, 50:80] = True
    return m


def test_mask_boundary_is_a_2px_douglas_peucker_of_the_contour():
    m = blob()
    P, raw = mask_boundary(m), raw_contour(m)
    assert len(P) < len(raw) / 3  # it did simplify
    assert not np.array_equal(P[0], P[-1])
    assert polygon_area(P) > 0
    assert point_to_polyline(raw, P).max() <= 2.0 + 1e-6  # every contour point within eps of the polyline
    assert point_to_polyline(P, raw).max() <= 1e-9  # every vertex lies on the contour
    assert iou(rasterize(P, m.shape), m) > 0.95


def test_simplify_keeps_requested_vertices():
    raw = raw_contour(blob())
    keep = np.array([5, 77, 140])
    Q, idx = simplify(raw, keep=keep)
    np.testing.assert_array_equal(Q[idx], raw[keep])
    assert np.all(np.diff(idx) > 0)
    assert point_to_polyline(raw, Q).max() <= 2.0 + 1e-6


def test_three_adjacent_clicks_become_one():
    clicks = np.array([[30.0, 30.0], [31.0, 30.0], [31.0, 31.0], [60.0, 60.0]])
    merged, warnings = merge_clicks(clicks)
    assert len(merged) == 2 and len(warnings) == 1
    assert np.allclose(merged[np.argmin(merged[:, 0])], [30 + 2 / 3, 30 + 1 / 3])


def test_junction_outside_is_moved_on_and_a_far_one_grows_the_region():
    fg = np.zeros((80, 80), bool)
    fg[10:70, 10:70] = True
    region = np.zeros_like(fg)
    region[30:50, 50:70] = True  # touches the foreground's right edge x = 69
    outside = [72.0, 40.0]  # 3 px right of the foreground (and of the region)
    far = [15.0, 15.0]  # inside the foreground, > 12 px from the region
    pose = np.array([[20.0, 40.0, 0.0], [60.0, 40.0, -1.0]])
    regions, _, per, warnings = assign_junctions(np.array([outside, far, [72.5, 40.5], [73.0, 39.5]]), [region],
                                                 [np.array([0])], fg, pose, STICK)
    assert len(per) == 1 and len(per[0]) == 2  # nothing is dropped
    x, y = per[0][0]
    assert fg[int(y), int(x)] and x == 69  # on the foreground boundary
    assert regions[0][15, 15] and regions[0].sum() > region.sum()  # grown along a strip out to the far click
    assert regions[0][region].all() and not (regions[0] & ~fg).any()
    assert any("merged" in w for w in warnings) and any("moved onto it" in w for w in warnings)
    assert any("grown" in w for w in warnings)


def test_junctions_go_to_nearest_region():
    fg = np.ones((80, 80), bool)
    a = np.zeros_like(fg)
    a[10:30, 10:30] = True
    b = np.zeros_like(fg)
    b[40:70, 40:70] = True
    pose = np.array([[20.0, 20.0, 0.0], [55.0, 55.0, 0.0]])
    _, _, per, warnings = assign_junctions(np.array([[32.0, 20.0], [38.0, 50.0], [45.0, 60.0], [55.0, 55.0]]), [a, b],
                                           [np.array([0]), np.array([0])], fg, pose, STICK)
    assert len(per[0]) == 1 and len(per[1]) == 3  # (55, 55) is 15 px deep inside b: b is reshaped through it
    assert any("inside occlusion region 1" in w for w in warnings)


def test_click_without_any_region_starts_one_in_front_of_it():
    """An arm (nearer, z = -1) over a torso: no predicted region, one click where the outlines meet."""
    fg = np.zeros((100, 100), bool)
    fg[20:90, 30:70] = True  # torso
    fg[45:55, 10:90] = True  # arm across it
    sk = Skeleton(joints=("hips", "neck", "shoulder", "hand"), parents=np.array([-1, 0, 1, 2]))
    pose = np.array([[50.0, 85.0, 0.0], [50.0, 25.0, 0.0], [15.0, 50.0, -1.0], [85.0, 50.0, -1.0]])
    click = np.array([[30.0, 45.0]])  # the arm's upper outline meets the torso's left outline
    regions, fronts, per, warnings = assign_junctions(click, [], [], fg, pose, sk)
    assert len(regions) == 1 and len(per[0]) == 1 and np.array_equal(fronts[0], [2])  # bone shoulder-hand
    ys, xs = np.nonzero(regions[0])
    assert ys.mean() > 45  # the region lies in the arm, below its upper outline
    assert np.hypot(xs - 30, ys - 45).min() <= 1.5  # and the click is on its rim
    assert any("started" in w for w in warnings)


def test_refine_region_passes_through_junctions():
    fg = np.zeros((96, 96), bool)
    fg[4:92, 4:92] = True
    m = blob()
    raw = raw_contour(m)
    normals_off = np.array([[40.0, 48 - 18 - 4], [40 + 26 + 3, 45.0], [65.0, 62.0]])  # 3-4 px off the boundary
    assert point_to_polyline(normals_off, raw).min() > 2.0
    warnings: list[str] = []
    refined, P, idx = refine_region(m, normals_off, fg, warnings)
    assert len(idx) == 3 and np.all(np.diff(idx) > 0)
    d = np.linalg.norm(P[idx][:, None] - normals_off[None], axis=2).min(axis=1)
    assert d.max() <= 0.5
    assert not (refined & ~fg).any()
    assert abs(int(refined.sum()) - int(m.sum())) < 0.15 * m.sum()
    assert polygon_area(P) > 0 and not np.array_equal(P[0], P[-1])
    far = np.linalg.norm(P[:, None] - normals_off[None], axis=2).min(axis=1) > 20
    assert far.sum() >= 2 and point_to_polyline(P[far], raw).max() <= 1.0  # held away from the junctions
    # the raster follows the polyline: each junction pixel is now inside or on the region's edge
    for x, y in normals_off:
        assert refined[int(round(y)) - 1 : int(round(y)) + 2, int(round(x)) - 1 : int(round(x)) + 2].any()


def test_refine_region_stays_inside_foreground():
    fg = np.zeros((96, 96), bool)
    fg[10:86, 10:60] = True
    m = np.zeros_like(fg)
    m[30:60, 30:60] = True  # its right side is the foreground's edge
    J = np.array([[59.0, 25.0], [45.0, 64.0]])  # pulls the region up along the edge and down
    refined, P, idx = refine_region(m, J, fg)
    assert not (refined & ~fg).any()
    d = np.linalg.norm(P[idx][:, None] - J[None], axis=2).min(axis=1)
    assert d.max() <= 0.5


def test_refine_region_without_junctions_is_unchanged():
    fg = np.ones((96, 96), bool)
    m = blob()
    refined, P, idx = refine_region(m, np.zeros((0, 2)), fg)
    assert np.array_equal(refined, m) and len(idx) == 0
    np.testing.assert_array_equal(P, mask_boundary(m))


def test_refine_masks_on_crossing_improves_the_prediction():
    drawing, pose, skeleton, true, _, _ = crossing_scene()
    masks = build_masks(drawing, pose, skeleton, occlusion="skeleton")  # a rough prediction for the clicks to fix
    contour = raw_contour(true)
    s, d = contour.sum(1), contour[:, 0] - contour[:, 1]
    corners = contour[[s.argmin(), s.argmax(), d.argmin(), d.argmax()]]  # where the arm's outline meets the torso's
    refined = refine_masks(masks, corners, pose, skeleton)
    best = int(np.argmax([iou(r, true) for r in refined.occlusion]))
    before = max(iou(r, true) for r in masks.occlusion)
    assert iou(refined.occlusion[best], true) > before + 0.05
    B, idx = refined.boundaries[best], refined.junctions[best]
    assert len(idx) == 4 and np.all(np.diff(idx) > 0)
    assert np.linalg.norm(B[idx][:, None] - corners[None], axis=2).min(axis=1).max() <= 0.5
    assert sum(polygon_area(L) for L in refined.domain) > 0
    assert len(refined.occlusion) == len(refined.front_bones) == len(refined.boundaries) == len(refined.junctions)
    assert refined.warnings[: len(masks.warnings)] == masks.warnings


def test_two_junctions_projecting_onto_one_corner_get_distinct_vertices():
    fg = np.ones((96, 96), bool)
    m = np.zeros_like(fg)
    m[30:60, 30:60] = True
    J = np.array([[61.0, 27.0], [64.0, 29.0]])  # both nearest to the corner (59, 30)
    refined, P, idx = refine_region(m, J, fg)
    assert len(np.unique(idx)) == 2
    d = np.linalg.norm(P[idx][:, None] - J[None], axis=2).min(axis=1)
    assert d.max() <= 0.5
    assert abs(int(refined.sum()) - int(m.sum())) < 0.15 * m.sum()


def test_rasterize_inverts_the_raw_contour():
    m = blob()
    assert np.array_equal(rasterize(raw_contour(m), m.shape), m)


def test_a_region_in_pieces_without_clicks_becomes_one_region_per_piece():
    # the skeleton's capsules can overlap into one mask of separate overlaps (a forearm across the chest, legs
    # behind a belly): a pocket is meshed from one boundary loop, so each piece must be a region of its own, or
    # only the largest is freed; a region with clicks keeps the piece its clicks refine
    from ops.geometry.template import build_template

    drawing, pose, skeleton, true, torso, _ = crossing_scene()
    masks = build_masks(drawing, pose, skeleton, occlusion="skeleton")
    low = torso & (np.arange(torso.shape[0])[:, None] > 112)  # the torso's bottom, apart from the forearm
    assert not (low & true).any()
    speck = np.zeros_like(low)
    speck[100:102, 79:82] = True  # 6 px inside the torso, apart from both: no region of its own
    assert not (speck & (low | true)).any() and torso[speck].all()
    masks.occlusion, masks.front_bones = [true | low | speck], [np.array([3])]
    refined = refine_masks(masks, np.zeros((0, 2)), pose, skeleton)
    assert len(refined.occlusion) == 2
    assert any("has 3 pieces: made one region of each of the 2 of at least 12 px (1 smaller left out)" in w
               for w in refined.warnings)
    for piece in (true, low):
        assert max(iou(m, piece) for m in refined.occlusion) > 0.9
    for m, B in zip(refined.occlusion, refined.boundaries):
        assert iou(rasterize(B, m.shape) & masks.foreground, m) > 0.9  # each boundary describes its own piece
    assert [f.tolist() for f in refined.front_bones] == [[3], [3]]
    base = build_template(refined, pose, skeleton)
    assert set(np.unique(base.face_region)) == {-1, 0, 1}  # both pieces are meshed as pockets
    clicked = refine_masks(masks, np.array([[60.0, 78.0]]), pose, skeleton)
    assert len(clicked.occlusion) == 1 and any("only the largest" in w for w in clicked.warnings)
    masks.occlusion = [true | speck]  # one piece left: no split, the speck left out
    alone = refine_masks(masks, np.zeros((0, 2)), pose, skeleton)
    assert len(alone.occlusion) == 1 and any("has 2 pieces: the 1 under 12 px left out" in w for w in alone.warnings)
    assert not (alone.occlusion[0] & speck).any()
