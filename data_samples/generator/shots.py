"""The sample shots of data_samples/: characters, key poses and how each is drawn."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .characters import TAIL_LENGTH, TAIL_PARENTS, human_pose, humanoid, tentacle
from .model import Character, scaled
from .poses import forward


@dataclass
class ShotSpec:
    """Everything needed to write one shot directory."""

    name: str
    char: Character
    keys: tuple[np.ndarray, np.ndarray]  # (J, 3) key poses
    size: tuple[int, int]  # (H, W)
    two_poses_only: bool = False  # write only the key poses plus "frames"
    manual_masks: bool = False  # write key0_fg.png / key0_occ*.png and list them in "masks"
    description: str = ""
    style: str | None = None  # a styles.STYLES name; None: the original ink renderer (legacy.py)
    palette: dict = field(default_factory=dict)  # material -> colour (styles.Palette)


def shot_no_occlusion() -> ShotSpec:
    """A humanoid waving its right arm above the shoulder; no part overlaps a non-adjacent one."""
    root = (128.0, 142.0)
    k0 = human_pose(root, {4: 205, 5: 258, 7: 70})
    k1 = human_pose(root, {4: 196, 5: 300, 7: 74})
    return ShotSpec("no_occlusion", humanoid(11), (k0, k1), (256, 256),
                    description="humanoid waving the right arm overhead; no occlusion in either key")


def shot_arm_cross() -> ShotSpec:
    """384 px humanoid: right forearm hangs beside the body at t=0 and crosses in front of the torso at t=1."""
    k = 1.5
    root = (192.0, 213.0)
    k0 = human_pose(root, {4: 104, 5: 97}, scale=k)
    k1 = human_pose(root, {4: 100, 5: -12}, scale=k)
    return ShotSpec("arm_cross", scaled(humanoid(12), k), (k0, k1), (384, 384),
                    description="right forearm swings up and crosses in front of the torso (occlusion only in key1)")


def shot_legs_cross() -> ShotSpec:
    """Legs apart at t=0; at t=1 the right leg crosses in front of the left."""
    root = (128.0, 132.0)
    k0 = human_pose(root, {10: 104, 11: 98, 13: 76, 14: 82})
    k1 = human_pose(root, {10: 82, 11: 58, 13: 95, 14: 112}, z={10: -0.8, 11: -0.8})
    return ShotSpec("legs_cross", humanoid(13), (k0, k1), (256, 256),
                    description="legs apart, then the right leg crosses in front of the left")


def shot_tail() -> ShotSpec:
    """The tentacle rises almost straight, then curls so its last segments pass in front of its base."""
    root = (80.0, 210.0)
    z = {j: -0.4 * j for j in range(7)}  # the tip is nearest the viewer
    k0 = forward(TAIL_PARENTS, root, {1: -84, 2: -74, 3: -62, 4: -50, 5: -38, 6: -26}, TAIL_LENGTH, z)
    k1 = forward(TAIL_PARENTS, root, {1: -80, 2: -20, 3: 50, 4: 150, 5: 180, 6: 190}, TAIL_LENGTH, z)
    return ShotSpec("tail", tentacle(14), (k0, k1), (256, 256),
                    description="6-segment tentacle curling so its tip passes in front of its base")


def shot_manual_masks() -> ShotSpec:
    """Right forearm in front of the torso at t=0, swung out to the side at t=1; key0 masks given by hand."""
    root = (128.0, 142.0)
    k0 = human_pose(root, {4: 100, 5: -14})
    k1 = human_pose(root, {4: 150, 5: 190})
    return ShotSpec("manual_masks", humanoid(15), (k0, k1), (256, 256), manual_masks=True,
                    description="right forearm in front of the torso in key0 (manual fg + occlusion masks), "
                                "raised to the side in key1")


def shot_two_poses() -> ShotSpec:
    """Only the key poses are given (plus frames = 9): the left forearm swings behind the torso."""
    root = (128.0, 142.0)
    k0 = human_pose(root, {7: 30, 8: 20, 4: 112})
    k1 = human_pose(root, {7: 82, 8: 188, 4: 112})
    return ShotSpec("two_poses", humanoid(16), (k0, k1), (256, 256), two_poses_only=True,
                    description="left forearm swings behind the torso; shot.json gives only the two key poses "
                                "and frames = 9")


SHOTS: dict[str, Callable[[], ShotSpec]] = {
    "no_occlusion": shot_no_occlusion, "arm_cross": shot_arm_cross, "legs_cross": shot_legs_cross,
    "tail": shot_tail, "manual_masks": shot_manual_masks, "two_poses": shot_two_poses,
}
