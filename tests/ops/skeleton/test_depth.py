"""Depth from a drawing: the part whose outline runs across the other is in front (smaller z)."""
import cv2
import numpy as np
import pytest
from scipy import ndimage

from ops.segmentation.bones import bone_depths
from ops.skeleton.depth import depth_order
from ops.types import Skeleton

# a body (hip -> neck) and an arm from the shoulder whose forearm swings across the body
JOINTS = ("hip", "neck", "shoulder", "elbow", "hand")
PARENTS = np.array([-1, 0, 1, 2, 3])
POSE = np.array([[100.0, 160.0], [100.0, 60.0], [70.0, 62.0], [55.0, 120.0], [125.0, 125.0]])


def part(img, a, b, r, fill):
    """A capsule from a to b of radius r: filled with `fill`, outlined in black."""
    mask = np.zeros(img.shape[:2], np.uint8)
    cv2.line(mask, tuple(map(int, a)), tuple(map(int, b)), 1, thickness=int(2 * r))
    inside = mask > 0
    img[inside] = fill
    edge = inside & ~ndimage.binary_erosion(inside, iterations=2)
    img[edge] = 0.0


def drawing(arm_in_front: bool):
    img = np.ones((200, 200, 3), np.float32)
    body = lambda: part(img, POSE[0], POSE[1], 22, 0.95)  # noqa: E731
    arm = lambda: (part(img, POSE[2], POSE[3], 8, 0.9), part(img, POSE[3], POSE[4], 7, 0.9))  # noqa: E731
    (body(), arm()) if arm_in_front else (arm(), body())
    mask = img.mean(2) < 0.99
    return img, ndimage.binary_fill_holes(mask)


@pytest.mark.parametrize("front", [True, False])
def test_the_forearm_drawn_over_the_body_is_nearer_and_drawn_under_it_farther(front):
    img, mask = drawing(front)
    sk = Skeleton(JOINTS, PARENTS)
    order = depth_order(img, mask, POSE, sk)
    depth = bone_depths(np.c_[POSE, order.z], sk)
    forearm, body = 3, 0  # bones in child order: (hip, neck), (neck, shoulder), (shoulder, elbow), (elbow, hand)
    assert order.decisions, "no overlap judged"
    assert (depth[forearm] < depth[body]) == front and depth[forearm] != depth[body]
