"""The sample shots of data_samples/: characters, key poses and how each is drawn."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .characters import (
    BEAR,
    DINO,
    FOX_RIG,
    LAMP_RIG,
    PERSON,
    TAIL_LENGTH,
    TAIL_PARENTS,
    bear,
    dinosaur,
    fox,
    human_pose,
    humanoid,
    lamp,
    person,
    tentacle,
    two_bone_ik,
)
from .model import Character, scaled
from .poses import forward
from .styles import BEAR as BEAR_COLOURS
from .styles import DINOSAUR, FOX, GIRL, KID, LAMP


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


def shot_watercolour() -> ShotSpec:
    """A watercolour girl without outlines; her right forearm swings across her body between the keys."""
    root = (128.0, 116.0)
    k0 = PERSON.pose(root, {4: 104, 5: 98, 7: 76, 8: 84})
    k1 = PERSON.pose(root, {4: 100, 5: -14, 7: 72, 8: 80, 2: -94})
    return ShotSpec("watercolour", person(21), (k0, k1), (256, 256), style="watercolour", palette=GIRL,
                    description="watercolour girl, no outlines, off-white paper; right forearm crosses in front of "
                                "her top in key1; the skirt covers the tops of the thighs in both keys")


def shot_flat_colour() -> ShotSpec:
    """A green dinosaur with a dark green outline: standing, then stepping with its arms swung."""
    root = (124.0, 142.0)
    k0 = DINO.pose(root)
    k1 = DINO.pose(root, {1: -32, 2: -62, 3: 14, 4: 168, 5: 160, 6: 150, 8: 75, 9: -10, 11: 105, 12: 40,
                          14: 60, 15: 110, 16: 10, 18: 110, 19: 95, 20: 0})
    return ShotSpec("flat_colour", dinosaur(22), (k0, k1), (256, 256), style="flat_colour", palette=DINOSAUR,
                    description="flat-colour dinosaur, dark green outline; near thigh and near arm over the round "
                                "belly in both keys; it steps and swings its arm and tail")


def shot_scan_jpeg() -> ShotSpec:
    """A photographed ink bear on unevenly lit paper (JPEG): it waves, then lays its forearm over its belly."""
    root = (128.0, 150.0)
    k0 = BEAR.pose(root, {6: 200, 7: 250})
    k1 = BEAR.pose(root, {6: 110, 7: -5})
    return ShotSpec("scan_jpeg", bear(23), (k0, k1), (256, 256), style="scan", palette=BEAR_COLOURS,
                    description="JPEG photo of an ink bear on unevenly lit paper; right arm raised in key0, "
                                "forearm across the belly in key1")


def shot_hand_on_hip() -> ShotSpec:
    """A pencil person with the right hand on the hip (key0), then behind the head (key1): both enclose paper."""
    root = (128.0, 120.0)
    rest = PERSON.pose(root)
    shoulder = rest[PERSON.index("r_shoulder"), :2]
    a4, a5 = two_bone_ik(shoulder, rest[0, :2] + np.array([-17.0, 0.0]), 29, 27, 1)  # elbow out to the side
    k0 = PERSON.pose(root, {4: a4, 5: a5})
    head_back = rest[PERSON.index("neck"), :2] + np.array([-4.0, -32.0])
    b4, b5 = two_bone_ik(shoulder, head_back, 29, 27, -1)  # elbow up, the forearm behind the head
    k1 = PERSON.pose(root, {4: b4, 5: b5, 2: -80}, z={4: -0.25, 5: 0.4})  # upper arm in front, forearm behind
    return ShotSpec("hand_on_hip", person(24, skirt=False, sleeves=False), (k0, k1), (256, 256), style="pencil",
                    palette=KID, description="pencil person; key0 right hand on the hip (arm and torso enclose "
                                              "paper), key1 hand behind the head (arm and head enclose paper)")


def shot_lamp() -> ShotSpec:
    """An ink desk lamp folded down so arms and base enclose a triangle (key0), then bent up and open (key1)."""
    root = (176.0, 214.0)
    k0 = LAMP_RIG.pose(root)
    k1 = LAMP_RIG.pose(root, {2: -76, 3: -14, 4: 62})
    return ShotSpec("lamp", lamp(25), (k0, k1), (256, 256), style="ink", palette=LAMP,
                    description="ink desk lamp; key0 the two arms and the base enclose a triangle of paper, "
                                "the shade rests on the base; key1 the lamp bends up and the triangle opens")


def shot_curled_tail() -> ShotSpec:
    """A flat-colour fox whose tail is stretched out (key0), then curled into a closed loop (key1)."""
    root, k = (140.0, 146.0), 1.25
    k0 = FOX_RIG.pose(root, {14: 200, 15: 196, 16: 192, 17: 190, 18: 192, 19: 196, 20: 202}, scale=k)
    curl = {14: 230, 15: 230} | {14 + j: 230 + 56 * (j - 1) for j in range(2, 7)}  # turns 56 deg per segment
    k1 = FOX_RIG.pose(root, curl, scale=k)
    return ShotSpec("curled_tail", fox(26, girth=k), (k0, k1), (256, 256), style="flat_colour", palette=FOX,
                    description="flat-colour fox, brown outline; tail stretched out in key0, curled into a "
                                "closed loop that encloses paper in key1")


SHOTS: dict[str, Callable[[], ShotSpec]] = {
    "no_occlusion": shot_no_occlusion, "arm_cross": shot_arm_cross, "legs_cross": shot_legs_cross,
    "tail": shot_tail, "manual_masks": shot_manual_masks, "two_poses": shot_two_poses,
    "watercolour": shot_watercolour, "flat_colour": shot_flat_colour, "scan_jpeg": shot_scan_jpeg,
    "hand_on_hip": shot_hand_on_hip, "lamp": shot_lamp, "curled_tail": shot_curled_tail,
}
NEW_SHOTS = ["watercolour", "flat_colour", "scan_jpeg", "hand_on_hip", "lamp", "curled_tail"]
