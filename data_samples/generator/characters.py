"""The characters: skeletons with drawn parts and their rest proportions (lengths px, angles deg, depths)."""
from __future__ import annotations

import numpy as np

from .model import Character, Part
from .poses import forward

# ----------------------------------------------------------------------------- the ink doll of the first shots

HUMAN_JOINTS = ["pelvis", "neck", "head", "r_shoulder", "r_elbow", "r_hand", "l_shoulder", "l_elbow", "l_hand",
                "r_hip", "r_knee", "r_foot", "l_hip", "l_knee", "l_foot"]
HUMAN_PARENTS = [-1, 0, 1, 1, 3, 4, 1, 6, 7, 0, 9, 10, 0, 12, 13]
HUMAN_LENGTH = {1: 50, 2: 30, 3: 24, 4: 31, 5: 29, 6: 24, 7: 31, 8: 29, 9: 16, 10: 38, 11: 36, 12: 16, 13: 38, 14: 36}
# standing: clavicles slightly down, arms hanging a little away from the body, legs slightly apart
HUMAN_REST = {1: -90, 2: -90, 3: 174, 4: 102, 5: 96, 6: 6, 7: 78, 8: 84, 9: 148, 10: 93, 11: 90, 12: 32, 13: 87, 14: 90}
# character's left side behind the torso, right side in front of it
HUMAN_Z = {0: 0.0, 1: 0.0, 2: -0.1, 3: -0.5, 4: -1.0, 5: -1.0, 6: 0.5, 7: 1.0, 8: 1.0,
           9: -0.2, 10: -0.4, 11: -0.4, 12: 0.2, 13: 0.4, 14: 0.4}


def humanoid(seed: int) -> Character:
    """A 15-joint doll: ellipse torso and head, capsule limbs; textures drawn from `seed`."""
    cap = lambda r, t, name: Part("capsule", r, 0.0, t, name=name)  # noqa: E731
    parts = {1: Part("ellipse", 16.5, 3.0, "buttons", name="torso"), 2: Part("ellipse", 13.0, 3.0, "face", name="head"),
             3: cap(5.5, "none", "r_clavicle"), 4: cap(6.5, "stripes", "r_upper_arm"), 5: cap(5.5, "dots", "r_forearm"),
             6: cap(5.5, "none", "l_clavicle"), 7: cap(6.5, "hatch", "l_upper_arm"), 8: cap(5.5, "zigzag", "l_forearm"),
             9: cap(6.0, "none", "r_hip"), 10: cap(7.5, "zigzag", "r_thigh"), 11: cap(6.5, "stripes", "r_shin"),
             12: cap(6.0, "none", "l_hip"), 13: cap(7.5, "dots", "l_thigh"), 14: cap(6.5, "hatch", "l_shin")}
    return Character(list(HUMAN_JOINTS), list(HUMAN_PARENTS), parts, seed)


def human_pose(root: tuple[float, float], angles: dict[int, float] | None = None, z: dict[int, float] | None = None,
               scale: float = 1.0) -> np.ndarray:
    """(15, 3) humanoid pose: rest angles overridden by `angles` (deg), depths by `z`, lengths times scale."""
    ang = {**HUMAN_REST, **(angles or {})}
    length = {c: v * scale for c, v in HUMAN_LENGTH.items()}
    return forward(HUMAN_PARENTS, root, ang, length, {**HUMAN_Z, **(z or {})})


TAIL_JOINTS = ["base", "s1", "s2", "s3", "s4", "s5", "tip"]
TAIL_PARENTS = [-1, 0, 1, 2, 3, 4, 5]
TAIL_LENGTH = {1: 43, 2: 39, 3: 35, 4: 32, 5: 29, 6: 26}


def tentacle(seed: int) -> Character:
    """A tapering 6-segment tentacle (non-humanoid) with ring and dot textures."""
    kinds = ["rings", "dots", "stripes", "zigzag", "rings", "dots"]
    radii = [12.5, 11.0, 9.5, 8.5, 7.5, 6.5]
    parts = {c: Part("capsule", radii[c - 1], 0.0, kinds[c - 1], name=f"segment{c}") for c in range(1, 7)}
    return Character(list(TAIL_JOINTS), list(TAIL_PARENTS), parts, seed)
