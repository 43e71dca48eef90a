"""The characters: skeletons with drawn parts and their rest proportions (lengths px, angles deg, depths)."""
from __future__ import annotations

import math
from dataclasses import dataclass

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


# ----------------------------------------------------------------------------- rigs of the new characters

@dataclass(frozen=True)
class Rig:
    """A skeleton's kinematics: joint names, parents, bone lengths (px), rest world angles (deg), depths."""

    joints: tuple[str, ...]
    parents: tuple[int, ...]
    length: dict[int, float]
    rest: dict[int, float]
    z: dict[int, float]

    def pose(self, root: tuple[float, float], angles: dict[int, float] | None = None,
             z: dict[int, float] | None = None, scale: float = 1.0,
             length: dict[int, float] | None = None) -> np.ndarray:
        """(J, 3) pose: rest angles overridden by `angles` (deg), depths by `z`, lengths by `length`, times scale."""
        lengths = {c: v * scale for c, v in {**self.length, **(length or {})}.items()}
        return forward(list(self.parents), root, {**self.rest, **(angles or {})}, lengths, {**self.z, **(z or {})})

    def index(self, name: str) -> int:
        """Joint index of a joint name."""
        return self.joints.index(name)


def two_bone_ik(s: np.ndarray, target: np.ndarray, l1: float, l2: float, bend: float) -> tuple[float, float]:
    """World angles (deg) of two chained bones from s (2,) whose end reaches target (2,); bend = +1 or -1
    picks the elbow side. Out of reach: the chain points straight at the target."""
    d = target - s
    dist = float(np.clip(np.hypot(*d), abs(l1 - l2) + 1e-6, l1 + l2 - 1e-6))
    base = math.atan2(d[1], d[0])
    alpha = math.acos(float(np.clip((l1 ** 2 + dist ** 2 - l2 ** 2) / (2 * l1 * dist), -1, 1)))
    a1 = base + bend * alpha
    elbow = s + l1 * np.array([math.cos(a1), math.sin(a1)])
    e = target - elbow
    return math.degrees(a1), math.degrees(math.atan2(e[1], e[0]))


# A front-view person: trapezoid torso (the top), skirt on the pelvis, tapered limbs, boots.
PERSON = Rig(
    joints=("pelvis", "neck", "head", "r_shoulder", "r_elbow", "r_hand", "l_shoulder", "l_elbow", "l_hand",
            "r_hip", "r_knee", "r_ankle", "r_toe", "l_hip", "l_knee", "l_ankle", "l_toe", "hem"),
    parents=(-1, 0, 1, 1, 3, 4, 1, 6, 7, 0, 9, 10, 11, 0, 13, 14, 15, 0),
    length={1: 48, 2: 30, 3: 19, 4: 29, 5: 27, 6: 19, 7: 29, 8: 27, 9: 11, 10: 38, 11: 36, 12: 11,
            13: 11, 14: 38, 15: 36, 16: 11, 17: 28},
    rest={1: -90, 2: -90, 3: 171, 4: 100, 5: 95, 6: 9, 7: 80, 8: 85, 9: 125, 10: 93, 11: 90, 12: 150,
          13: 55, 14: 87, 15: 90, 16: 30, 17: 90},
    # right limbs in front of the torso, left ones behind; the top's hem over the thighs, the skirt over both
    z={0: 0.0, 1: -0.7, 2: -0.1, 3: -0.5, 4: -1.0, 5: -1.0, 6: 0.5, 7: 1.0, 8: 1.0, 9: 0.1, 10: -0.4, 11: -0.4,
       12: -0.6, 13: 0.3, 14: 0.4, 15: 0.4, 16: 0.2, 17: -0.9},
)


def person(seed: int, skirt: bool = True, girth: float = 1.0, sleeves: bool = True) -> Character:
    """A front-view person (PERSON rig): top, skirt over the thighs (or none), trousers, boots, hair.

    girth scales every half-width (a stocky or a slim person)."""
    g = girth
    arm_top = "top" if sleeves else "skin"
    parts = {1: Part("trapezoid", 13 * g, 6 * g, "folds", radius1=19 * g, material="top", name="top"),
             2: Part("ellipse", 13 * g, 3 * g, "hair", material="skin", name="head"),
             3: Part("none", 0), 6: Part("none", 0),
             17: Part("trapezoid", 15 * g, 3 * g, "folds", radius1=23 * g, material="skirt", name="skirt")
             if skirt else Part("none", 0)}
    for side, s0 in (("r", 4), ("l", 7)):
        parts[s0] = Part("taper", 6.0 * g, 0, "folds", radius1=5.0 * g, material=arm_top, name=f"{side}_upper_arm")
        parts[s0 + 1] = Part("taper", 4.8 * g, 0, "none", radius1=4.3 * g, material="skin", name=f"{side}_forearm")
    for side, h in (("r", 10), ("l", 14)):
        parts[h - 1] = Part("capsule", 8.0 * g, 0, "none", material="trousers", name=f"{side}_hip")  # closes the crotch
        parts[h] = Part("taper", 8.0 * g, 0, "folds", radius1=6.5 * g, material="trousers", name=f"{side}_thigh",
                        joined=True)
        parts[h + 1] = Part("taper", 6.3 * g, 0, "boot_shaft", radius1=5.6 * g, material="trousers", name=f"{side}_shin")
        parts[h + 2] = Part("taper", 5.6 * g, 0, "none", radius1=4.6 * g, material="boots", name=f"{side}_boot",
                            joined=True)
    return Character(list(PERSON.joints), list(PERSON.parents), parts, seed)


# A side-view dinosaur facing right: big round body with a pale belly, round near thigh, tail, small arms.
DINO = Rig(
    joints=("pelvis", "chest", "neck", "snout", "tail1", "tail2", "tail3", "r_shoulder", "r_elbow", "r_hand",
            "l_shoulder", "l_elbow", "l_hand", "r_hip", "r_knee", "r_ankle", "r_toe", "l_hip", "l_knee", "l_ankle",
            "l_toe"),
    parents=(-1, 0, 1, 2, 0, 4, 5, 1, 7, 8, 1, 10, 11, 0, 13, 14, 15, 0, 17, 18, 19),
    length={1: 46, 2: 26, 3: 32, 4: 30, 5: 28, 6: 26, 7: 14, 8: 17, 9: 15, 10: 14, 11: 17, 12: 15,
            13: 9, 14: 26, 15: 24, 16: 14, 17: 9, 18: 26, 19: 24, 20: 14},
    rest={1: -38, 2: -70, 3: 8, 4: 172, 5: 178, 6: 190, 7: 110, 8: 100, 9: 25, 10: 70, 11: 100, 12: 25,
          13: 70, 14: 85, 15: 100, 16: 5, 17: 40, 18: 88, 19: 100, 20: 5},
    z={0: 0.0, 1: 0.0, 2: -0.05, 3: -0.1, 4: 0.05, 5: 0.1, 6: 0.15, 7: -0.2, 8: -0.5, 9: -0.6,
       10: 0.2, 11: 0.5, 12: 0.6, 13: -0.2, 14: -0.4, 15: -0.5, 16: -0.6, 17: 0.2, 18: 0.4, 19: 0.5, 20: 0.6},
)


def dinosaur(seed: int, girth: float = 1.0) -> Character:
    """A cartoon dinosaur (DINO rig): round belly, round thighs drawn inside the body, tapered tail."""
    g = girth
    parts = {1: Part("ellipse", 33 * g, 12 * g, "belly", offset=3 * g, material="body", name="body"),
             2: Part("taper", 13 * g, 0, "none", radius1=10 * g, material="body", name="neck"),
             3: Part("taper", 12 * g, 0, "face_side", radius1=8 * g, material="body", name="head", joined=True),
             4: Part("taper", 19 * g, 0, "spots", radius1=13 * g, material="body", name="tail_base"),
             5: Part("taper", 13 * g, 0, "spots", radius1=7.5 * g, material="body", name="tail_mid", joined=True),
             6: Part("taper", 7.5 * g, 0, "none", radius1=2 * g, material="body", name="tail_tip", joined=True),
             7: Part("none", 0), 10: Part("none", 0), 13: Part("none", 0), 17: Part("none", 0)}
    for side, s0 in (("r", 8), ("l", 11)):
        parts[s0] = Part("taper", 6 * g, 0, "none", radius1=5 * g, material="body", name=f"{side}_upper_arm")
        parts[s0 + 1] = Part("taper", 5 * g, 0, "none", radius1=3.5 * g, material="body", name=f"{side}_forearm")
    for side, h in (("r", 14), ("l", 18)):
        parts[h] = Part("ellipse", 14 * g, 6 * g, "crosshatch", material="body", name=f"{side}_thigh")
        parts[h + 1] = Part("taper", 8.5 * g, 0, "none", radius1=7 * g, material="body", name=f"{side}_shin")
        parts[h + 2] = Part("taper", 7 * g, 0, "none", radius1=4.5 * g, material="body", name=f"{side}_foot",
                            joined=True)
    return Character(list(DINO.joints), list(DINO.parents), parts, seed)


# A front-view bear: round belly, round head with ears, stubby limbs under and over the belly.
BEAR = Rig(
    joints=("pelvis", "chest", "head", "r_ear", "l_ear", "r_shoulder", "r_elbow", "r_hand", "l_shoulder",
            "l_elbow", "l_hand", "r_hip", "r_knee", "r_foot", "l_hip", "l_knee", "l_foot"),
    parents=(-1, 0, 1, 2, 2, 1, 5, 6, 1, 8, 9, 0, 11, 12, 0, 14, 15),
    length={1: 44, 2: 19, 3: 20, 4: 20, 5: 24, 6: 24, 7: 22, 8: 24, 9: 24, 10: 22, 11: 16, 12: 22, 13: 20,
            14: 16, 15: 22, 16: 20},
    rest={1: -90, 2: -90, 3: -130, 4: -50, 5: 168, 6: 115, 7: 100, 8: 12, 9: 65, 10: 80, 11: 112, 12: 95,
          13: 90, 14: 68, 15: 85, 16: 90},
    # arms in front of the belly, legs behind it (the belly hides the tops of the thighs), ears behind the head
    z={0: 0.0, 1: 0.0, 2: -0.1, 3: 0.2, 4: 0.2, 5: -0.3, 6: -0.8, 7: -0.9, 8: -0.3, 9: -0.6, 10: -0.7,
       11: 0.3, 12: 0.5, 13: 0.5, 14: 0.3, 15: 0.5, 16: 0.5},
)


def bear(seed: int, girth: float = 1.0) -> Character:
    """A cartoon bear (BEAR rig): big elliptical belly with a belly line and hatching, round head, ears."""
    g = girth
    parts = {1: Part("ellipse", 33 * g, 14 * g, "tummy", material="body", name="body"),
             2: Part("head", 20 * g, 17 * g, "face_front", material="body", name="head"),
             3: Part("taper", 2 * g, 0, "none", radius1=7.5 * g, material="body", name="r_ear"),
             4: Part("taper", 2 * g, 0, "none", radius1=7.5 * g, material="body", name="l_ear"),
             5: Part("none", 0), 8: Part("none", 0), 11: Part("none", 0), 14: Part("none", 0)}
    for side, s0 in (("r", 6), ("l", 9)):
        parts[s0] = Part("taper", 9 * g, 0, "fur", radius1=8 * g, material="body", name=f"{side}_upper_arm")
        parts[s0 + 1] = Part("taper", 8 * g, 0, "none", radius1=7.5 * g, material="body", name=f"{side}_forearm")
    for side, h in (("r", 12), ("l", 15)):
        parts[h] = Part("ellipse", 12 * g, 4 * g, "fur", material="body", name=f"{side}_thigh")
        parts[h + 1] = Part("taper", 10 * g, 0, "none", radius1=11 * g, material="body", name=f"{side}_foot")
    return Character(list(BEAR.joints), list(BEAR.parents), parts, seed)


# A desk lamp: a flat base, a lower and an upper arm hinged at the elbow, a conical shade.
LAMP_RIG = Rig(
    joints=("base_r", "base_l", "elbow", "wrist", "shade"),
    parents=(-1, 0, 1, 2, 3),
    length={1: 66, 2: 78, 3: 70, 4: 26},
    rest={1: 180, 2: -62, 3: 58, 4: 35},
    z={0: 0.0, 1: 0.0, 2: -0.2, 3: -0.4, 4: -0.6},  # the upper arm overlaps the lower at the elbow
)


def lamp(seed: int, girth: float = 1.0) -> Character:
    """A desk lamp (LAMP_RIG): base slab, two thin arms with pivot rings, a trapezoid shade."""
    g = girth
    parts = {1: Part("ellipse", 7 * g, 9 * g, "hatch", material="metal", name="base"),
             2: Part("capsule", 4.2 * g, 0, "hinge", material="metal", name="lower_arm"),
             3: Part("capsule", 4.2 * g, 0, "hinge", material="metal", name="upper_arm"),
             4: Part("trapezoid", 6 * g, 4 * g, "shade", radius1=19 * g, material="shade", name="shade")}
    return Character(list(LAMP_RIG.joints), list(LAMP_RIG.parents), parts, seed)


# A side-view fox facing right with a long bushy tail of seven segments that can curl into a loop.
FOX_RIG = Rig(
    joints=("pelvis", "chest", "neck", "snout", "r_ear", "l_ear", "r_elbow", "r_fpaw", "l_elbow", "l_fpaw",
            "r_knee", "r_bpaw", "l_knee", "l_bpaw", "t1", "t2", "t3", "t4", "t5", "t6", "t7"),
    parents=(-1, 0, 1, 2, 2, 2, 1, 6, 1, 8, 0, 10, 0, 12, 0, 14, 15, 16, 17, 18, 19),
    length={1: 50, 2: 16, 3: 26, 4: 15, 5: 15, 6: 20, 7: 19, 8: 20, 9: 19, 10: 22, 11: 21, 12: 22, 13: 21,
            14: 14, 15: 14, 16: 14, 17: 14, 18: 14, 19: 14, 20: 12},
    rest={1: -4, 2: -62, 3: 12, 4: -78, 5: -102, 6: 96, 7: 88, 8: 80, 9: 92, 10: 100, 11: 80, 12: 75, 13: 95,
          14: 200, 15: 200, 16: 200, 17: 200, 18: 200, 19: 200, 20: 200},
    z={0: 0.0, 1: 0.0, 2: -0.05, 3: -0.1, 4: -0.05, 5: 0.3, 6: -0.4, 7: -0.5, 8: 0.4, 9: 0.5, 10: -0.4, 11: -0.5,
       12: 0.4, 13: 0.5, 14: 0.1, 15: 0.05, 16: 0.0, 17: -0.05, 18: -0.1, 19: -0.15, 20: -0.2},
)


def fox(seed: int, girth: float = 1.0) -> Character:
    """A cartoon fox (FOX_RIG): pointed head, ears, pale belly, thin legs, bushy tail with a pale tip."""
    g = girth
    parts = {1: Part("ellipse", 17 * g, 8 * g, "belly", material="body", name="body"),
             2: Part("taper", 9 * g, 0, "fur", radius1=9.5 * g, material="body", name="neck"),
             3: Part("taper", 11 * g, 0, "face_side", radius1=3 * g, material="body", name="head", joined=True),
             4: Part("taper", 5 * g, 0, "none", radius1=1.2 * g, material="body", name="r_ear"),
             5: Part("taper", 5 * g, 0, "none", radius1=1.2 * g, material="body", name="l_ear")}
    for side, j in (("r", 6), ("l", 8)):
        parts[j] = Part("taper", 5.5 * g, 0, "none", radius1=4 * g, material="body", name=f"{side}_upper_foreleg")
        parts[j + 1] = Part("taper", 4 * g, 0, "none", radius1=3.6 * g, material="body", name=f"{side}_fore_paw",
                            joined=True)
    for side, j in (("r", 10), ("l", 12)):
        parts[j] = Part("ellipse", 8.5 * g, 4 * g, "fur", material="body", name=f"{side}_thigh")
        parts[j + 1] = Part("taper", 4.2 * g, 0, "none", radius1=3.6 * g, material="body", name=f"{side}_hind_paw")
    radii = [5.0, 7.0, 8.5, 9.0, 8.5, 7.0, 5.0, 1.5]
    for k in range(7):
        parts[14 + k] = Part("taper", radii[k] * g, 0, "tail_tip" if k == 6 else "fur", radius1=radii[k + 1] * g,
                             material="body", name=f"tail{k + 1}", joined=k > 0)
    return Character(list(FOX_RIG.joints), list(FOX_RIG.parents), parts, seed)
