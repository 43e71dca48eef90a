"""Tests of ops.motion.canvas: a drawing's outline carried with its bones, and the canvas grown to hold it."""
from __future__ import annotations

import numpy as np

from ops.motion.canvas import MARGIN_PX, carried_with_bones, outline_points, pad_drawing, padding_for
from ops.types import Skeleton

ARM = Skeleton(("shoulder", "elbow", "hand"), np.array([-1, 0, 1]))
POSE = np.array([[50.0, 50.0, 0.0], [50.0, 80.0, 0.0], [50.0, 110.0, 0.0]])  # hanging straight down


def turned(angle: float) -> np.ndarray:
    """POSE with the whole arm turned by `angle` radians about the shoulder."""
    c, s = np.cos(angle), np.sin(angle)
    out = POSE.copy()
    out[:, :2] = POSE[0, :2] + (POSE[:, :2] - POSE[0, :2]) @ np.array([[c, s], [-s, c]])
    return out


def test_points_ride_rigidly_with_their_nearest_bone():
    points = np.array([[58.0, 60.0], [42.0, 100.0], [50.0, 115.0]])  # beside the upper arm, the forearm, past the hand
    same = carried_with_bones(points, POSE, POSE[None], ARM)[0]
    np.testing.assert_allclose(same, points, atol=1e-9)
    moved = POSE.copy()
    moved[:, :2] += [7.0, -3.0]
    np.testing.assert_allclose(carried_with_bones(points, POSE, moved[None], ARM)[0], points + [7.0, -3.0], atol=1e-9)
    # the whole arm turned: every point turns with it about the shoulder, its distances kept
    for angle in (0.4, np.pi / 2, -2.0):
        there = carried_with_bones(points, POSE, turned(angle)[None], ARM)[0]
        c, s = np.cos(angle), np.sin(angle)
        expect = POSE[0, :2] + (points - POSE[0, :2]) @ np.array([[c, s], [-s, c]])
        np.testing.assert_allclose(there, expect, atol=1e-9)


def test_a_bone_that_lengthens_stretches_along_it_and_keeps_the_offset_across():
    longer = POSE.copy()
    longer[1:, 1] = [95.0, 125.0]  # upper arm 30 -> 45 px, the forearm moved down with it
    point = np.array([[56.0, 65.0]])  # half way down the upper arm, 6 px to its side
    np.testing.assert_allclose(carried_with_bones(point, POSE, longer[None], ARM)[0], [[56.0, 72.5]], atol=1e-9)


def test_padding_reaches_every_point_with_the_margin_and_nothing_more():
    size = (100, 80)  # (H, W)
    assert padding_for(np.array([[10.0, 10.0], [60.0, 80.0]]), size) == (0, 0, 0, 0)
    pad = padding_for(np.array([[-5.0, 20.0], [90.0, 103.5]]), size)
    assert pad == (5 + MARGIN_PX, 0, 90 + MARGIN_PX - 79, int(np.ceil(103.5 + MARGIN_PX - 99)))
    assert padding_for(np.zeros((0, 2)), size) == (0, 0, 0, 0)
    # a drawing cropped 2 px above the bottom edge: a motion that keeps its feet there grows nothing below
    rest = np.array([[20.0, 30.0], [60.0, 97.0]])
    assert padding_for(rest, size, rest=rest) == (0, 0, 0, 0)
    assert padding_for(rest + [0.0, 5.0], size, rest=rest) == (0, 0, 0, 5)  # moved 5 px lower: 5 px, no more
    assert padding_for(rest + [-25.0, 0.0], size, rest=rest) == (5 + MARGIN_PX, 0, 0, 0)  # the left keeps its margin


def test_a_padded_drawing_keeps_its_pixels_and_gets_the_papers_colour_around():
    rng = np.random.default_rng(0)
    img = np.full((30, 20, 3), (0.9, 0.85, 0.8), np.float32) + rng.normal(0, 0.01, (30, 20, 3)).astype(np.float32)
    mask = np.zeros((30, 20), bool)
    mask[5:30, 6:14] = True  # the character, cut off at the bottom edge
    img[mask] = 0.1
    out = pad_drawing(img, (3, 4, 5, 6), ~mask)
    assert out.shape == (40, 28, 3)
    np.testing.assert_array_equal(out[4:34, 3:23], img)
    border = np.ones(out.shape[:2], bool)
    border[4:34, 3:23] = False
    np.testing.assert_allclose(out[border], np.median(img[~mask], axis=0)[None].repeat(border.sum(), 0))
    assert out[34:, 3 + 6:3 + 14].min() > 0.5  # the feet cut at the edge are not smeared onto the new paper


def test_a_cut_out_grows_transparent():
    img = np.zeros((10, 10, 4), np.float32)
    img[3:7, 3:7] = (0.2, 0.3, 0.4, 1.0)
    out = pad_drawing(img, (2, 2, 2, 2), np.ones((10, 10), bool))
    assert out.shape == (14, 14, 4) and out[0, 0, 3] == 0.0
    np.testing.assert_array_equal(out[2:12, 2:12], img)


def test_outline_points_follow_the_outer_outline():
    mask = np.zeros((40, 40), bool)
    mask[10:30, 5:25] = True
    mask[15:20, 10:15] = False  # a hole: not an outer outline
    pts = outline_points(mask, step=1)
    assert pts[:, 0].min() == 5 and pts[:, 0].max() == 24 and pts[:, 1].min() == 10 and pts[:, 1].max() == 29
    assert not ((pts[:, 0] > 9) & (pts[:, 0] < 15) & (pts[:, 1] > 14) & (pts[:, 1] < 20)).any()
