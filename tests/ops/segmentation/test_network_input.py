"""The occlusion network's view of a keyframe: crop, working scale, and back to the keyframe."""
from __future__ import annotations

import cv2
import numpy as np

from ops.segmentation.network_input import (
    WORK_EXTENT_PX,
    from_work,
    network_input,
    paper_colour,
    to_work,
    work_frame,
    working_zoom,
)
from ops.segmentation.occlusion_net import IN_CHANNELS, STRIDE
from ops.types import Skeleton

SKELETON = Skeleton(("a", "b", "c"), np.array([-1, 0, 1]))


def scene(size: int = 400, zoom_extent: float = 300.0):
    """A cream page with a dark disc at each joint of a 3-joint pose spanning zoom_extent px."""
    img = np.full((size, size, 3), (240, 232, 220), np.uint8)
    pose = np.array([[50, 50, 0.0], [50 + zoom_extent, 50, 0.5], [50 + zoom_extent, 50 + zoom_extent / 2, 1.0]])
    for x, y, _ in pose:
        cv2.circle(img, (int(x), int(y)), 6, (20, 20, 20), -1)
    fg = np.zeros((size, size), bool)
    fg[40:60 + int(zoom_extent / 2), 40:361] = True
    return img, fg, pose


def test_zoom_brings_the_joints_to_the_working_extent():
    _, _, pose = scene()
    assert abs(working_zoom(pose) * 300 - WORK_EXTENT_PX) < 1e-6
    tiny = pose.copy()
    tiny[:, :2] *= 0.01
    assert working_zoom(tiny) == 4.0  # capped


def test_joints_land_on_their_discs_at_the_working_scale():
    img, fg, pose = scene()
    x, frame = network_input(img, fg, pose, SKELETON)
    assert x.shape[0] == IN_CHANNELS and x.shape[1] % STRIDE == 0 and x.shape[2] % STRIDE == 0
    work = to_work(pose, frame)
    dark = x[:3].mean(axis=0)  # paper is 0, ink strongly negative
    for jx, jy, _ in work:
        assert dark[int(round(jy)), int(round(jx))] < -0.8
    assert abs(np.ptp(work[:, 0]) - WORK_EXTENT_PX) < 1.0
    # the joint channel peaks on the joints too
    for jx, jy, _ in work:
        assert x[3 + 7, int(round(jy)), int(round(jx))] > 0.8


def test_map_round_trip_keeps_a_region():
    img, fg, pose = scene()
    frame = work_frame(fg, pose)
    region = np.zeros(fg.shape, np.float32)
    cv2.circle(region, (200, 100), 30, 1.0, -1)
    x0, y0, x1, y1 = frame.box
    h, w = frame.work_shape()
    small = cv2.resize(region[y0:y1, x0:x1], (w, h), interpolation=cv2.INTER_AREA)
    back = from_work(np.pad(small, ((0, 5), (0, 7))), frame, fg.shape) > 0.5  # padding is ignored
    truth = region > 0.5
    assert (back & truth).sum() / (back | truth).sum() > 0.95


def test_paper_colour_ignores_the_character():
    img, _, _ = scene()
    img[100:300, 100:300] = (200, 30, 30)  # a big red part: 25% of the page
    np.testing.assert_allclose(paper_colour(img), (240, 232, 220), atol=1)
