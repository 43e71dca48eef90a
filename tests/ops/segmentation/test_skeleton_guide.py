"""The skeleton channels of the occlusion network, on skeletons whose answer is known by hand."""
from __future__ import annotations

import numpy as np

from ops.segmentation.bones import segment_distance
from ops.segmentation.skeleton_guide import DIST_SCALE_PX, GUIDE_CHANNELS, bone_distance_stack, guide_channels
from ops.types import Skeleton


def cross_skeleton():
    """Two separate chains crossing at (50, 50): a horizontal arm in front (z = -1) of a vertical body (z = 0)."""
    skeleton = Skeleton(("hips", "neck", "shoulder", "hand"), np.array([-1, 0, -1, 2]))
    pose = np.array([[50, 90, 0.0], [50, 10, 0.0], [10, 50, -1.0], [90, 50, -1.0]])
    return skeleton, pose


def test_bone_distance_stack_matches_segment_distance():
    rng = np.random.default_rng(0)
    ends = rng.uniform(0, 50, (5, 2, 2))
    ends[4, 1] = ends[4, 0]  # a zero-length bone (root and hip at one spot)
    pts = rng.uniform(-10, 60, (300, 2))
    got = bone_distance_stack(pts, ends)
    for b in range(5):
        np.testing.assert_allclose(got[b], segment_distance(pts, ends[b, 0], ends[b, 1]), atol=1e-3)


def test_channels_at_known_pixels():
    skeleton, pose = cross_skeleton()
    g = guide_channels(pose, skeleton, (100, 100))
    assert g.shape == (GUIDE_CHANNELS, 100, 100) and g.dtype == np.float32
    # on the body bone at (50, 80): nearest is the body (d = 0), second the arm 30 px above
    assert g[0, 80, 50] == 1.0
    np.testing.assert_allclose(g[1, 80, 50], np.exp(-30 / DIST_SCALE_PX), rtol=1e-5)
    assert g[3, 80, 50] < -0.99  # the second nearest (the arm) is nearer the viewer
    # on the arm at (20, 50): the arm is nearest, the body behind it
    assert g[3, 50, 20] > 0.99
    assert g[5, 50, 20] == 0.0  # the two bones share no joint
    np.testing.assert_allclose(g[7, 90, 50], 1.0)  # on the hips joint
    assert g[7, 70, 50] < 0.1  # 20 px from every joint


def test_adjacent_flag_at_an_elbow():
    skeleton = Skeleton(("shoulder", "elbow", "hand"), np.array([-1, 0, 1]))
    pose = np.array([[10, 10, 0.0], [50, 10, 0.0], [50, 60, 0.0]])
    g = guide_channels(pose, skeleton, (70, 70))
    assert g[5, 14, 46] == 1.0  # near the elbow the two nearest bones are upper arm and forearm
    assert (g[3:5] == 0).all()  # equal depths: no order


def test_mirroring_the_pose_mirrors_the_channels():
    skeleton, pose = cross_skeleton()
    pose = pose.copy()
    pose[3, :2] = (80, 35)  # break the symmetry
    g = guide_channels(pose, skeleton, (100, 100))
    mirrored = pose.copy()
    mirrored[:, 0] = 99 - mirrored[:, 0]
    gm = guide_channels(mirrored, skeleton, (100, 100))
    np.testing.assert_allclose(gm[[0, 1, 2, 7]], g[[0, 1, 2, 7], :, ::-1], atol=1e-5)
