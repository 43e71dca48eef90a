"""Body families in 3D for the occlusion generator: rigs, random proportions, posed bodies and surface marks.

World axes of every body: x = the character's left, y = up, z = forward (the way it faces); units are
arbitrary (a person is about 100 tall). A Body holds the posed joints, the solids on its bones and the marks
drawn on their surfaces (stripes, spots, eyes), all in world coordinates; bodies_on_camera (in render3d)
projects them. Families:
- round: chubby people, big belly and head, thick limbs;
- thin: slender people and stick-like figures;
- quadruped: pigs, dogs, horses, cats (a horizontal body, four legs, a tail);
- props: a person holding a stick, a ball, a box or a bag;
- creature: a tailed biped (a dinosaur, a bird, a kangaroo): the body family held out of training.
Poses come from BVH clips (people; retargeted by bone direction, bvh.humanoid_joints) or are procedural
(people: standing, walking, reaching across the body, crossing the legs, sitting; animals: gaits).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .bvh import Motion, canonical_frame, humanoid_joints
from .solids import Solid, ellipsoid, frame_along, limb

FAMILIES = ("round", "thin", "quadruped", "props", "creature")
UP, LEFT, FORWARD = np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])


@dataclass
class Mark:
    """A stroke drawn on a body's surface: kind 'curve' ((n, 3) points, width) or 'spot' ((1, 3) point, radius);
    width in world units; solid: the index of the solid it lies on (hidden where another is in front)."""

    kind: str
    points: np.ndarray
    width: float
    solid: int


@dataclass
class Body:
    """A posed character: joints, parents, (J, 3) world positions, solids (bone = child joint index) and marks.

    ad_joints: the joints a user of the AnimatedDrawings-style skeleton would place (the others can be left
    out of the sample's skeleton; their bodies then belong to the nearest kept bone up the chain);
    ad_moves: {joint: (3,) position} where that skeleton puts a kept joint elsewhere (its neck at the head's
    centre)."""

    family: str
    joints: list[str]
    parents: list[int]
    pose: np.ndarray
    solids: list[Solid] = field(default_factory=list)
    marks: list[Mark] = field(default_factory=list)
    ad_joints: tuple[str, ...] = ()
    ad_moves: dict[str, np.ndarray] = field(default_factory=dict)
    motion: str = "procedural"

    def index(self, name: str) -> int:
        return self.joints.index(name)


# ----------------------------------------------------------------------------- small geometry

def unit(v: np.ndarray) -> np.ndarray:
    """v / |v| ((3,))."""
    return np.asarray(v, np.float64) / max(float(np.linalg.norm(v)), 1e-12)


def rotate(v: np.ndarray, axis: np.ndarray, deg: float) -> np.ndarray:
    """(3,) v rotated by `deg` degrees about `axis` (Rodrigues)."""
    k = unit(axis)
    a = math.radians(deg)
    return v * math.cos(a) + np.cross(k, v) * math.sin(a) + k * (k @ v) * (1 - math.cos(a))


def direction(down_deg: float, azimuth_deg: float, frame: np.ndarray | None = None) -> np.ndarray:
    """Unit vector `down_deg` from straight down, turned `azimuth_deg` about the vertical (0 = forward, 90 =
    the character's left), in the body axes of `frame` ((3, 3) rows left, up, forward; default the world's)."""
    f = np.eye(3) if frame is None else frame
    t, p = math.radians(down_deg), math.radians(azimuth_deg)
    local = np.array([math.sin(t) * math.sin(p), -math.cos(t), math.sin(t) * math.cos(p)])
    return local @ f


def two_bone_ik(a: np.ndarray, target: np.ndarray, l1: float, l2: float, pole: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Middle and end joint (3,) of a chain from a with lengths l1, l2 reaching toward target, the middle
    joint bent toward `pole` (a direction). Out of reach: straight at the target."""
    d = target - a
    dist = float(np.clip(np.linalg.norm(d), abs(l1 - l2) + 1e-6, l1 + l2 - 1e-6))
    u = unit(d)
    x = (l1 ** 2 - l2 ** 2 + dist ** 2) / (2 * dist)
    h = math.sqrt(max(l1 ** 2 - x ** 2, 0.0))
    side = pole - u * (pole @ u)
    side = unit(side) if np.linalg.norm(side) > 1e-9 else frame_along(u)[1]
    mid = a + u * x + side * h
    return mid, mid + l2 * unit(a + u * dist - mid)


def on_ellipsoid(s: Solid, local_dir: np.ndarray) -> np.ndarray:
    """(3,) the point of an ellipsoid's surface in the direction `local_dir` of its own axes."""
    return s.centre + (unit(local_dir) * s.radii) @ s.axes


def ring(c: np.ndarray, axis: np.ndarray, r: float, n: int = 24) -> np.ndarray:
    """(n + 1, 3) closed circle of radius r around `axis` at c."""
    f = frame_along(axis)
    a = np.linspace(0, 2 * math.pi, n + 1)
    return c + r * (np.cos(a)[:, None] * f[1] + np.sin(a)[:, None] * f[2])


# ----------------------------------------------------------------------------- people

HUMAN = ["root", "hip", "torso", "neck", "head", "right_shoulder", "right_elbow", "right_hand", "left_shoulder",
         "left_elbow", "left_hand", "right_hip", "right_knee", "right_foot", "right_toe", "left_hip", "left_knee",
         "left_foot", "left_toe"]
HUMAN_PARENTS = [-1, 0, 1, 2, 3, 2, 5, 6, 2, 8, 9, 0, 11, 12, 13, 0, 15, 16, 17]
AD_HUMAN = ("root", "hip", "torso", "neck", "right_shoulder", "right_elbow", "right_hand", "left_shoulder",
            "left_elbow", "left_hand", "right_hip", "right_knee", "right_foot", "left_hip", "left_knee", "left_foot")


@dataclass
class Build:
    """A person's proportions (world units) and clothes."""

    spine: float
    neck: float
    head_r: float
    shoulder: float
    upper_arm: float
    forearm: float
    arm_r: float
    hip: float
    thigh: float
    shin: float
    leg_r: float
    foot: float
    torso_w: float
    torso_d: float
    belly: float  # 0: none; else the belly's radius as a share of the shoulder width
    skirt: float  # 0: none; else the skirt's length as a share of the thigh
    sleeves: float  # 0: bare arms, 0.5: short sleeves, 1: long
    trousers: float  # 0: bare legs, 0.5: shorts, 1: long


def person_build(rng: np.random.Generator, family: str) -> Build:
    """Random proportions of a person of the `round` or `thin` family (props: either)."""
    j = lambda lo, hi: float(rng.uniform(lo, hi))  # noqa: E731
    if family == "props":
        family = "round" if rng.random() < 0.4 else "thin"
    if family == "round":
        head_r, arm_r, leg_r = j(10, 15), j(3.8, 6.5), j(5.0, 8.5)
        shoulder, torso_w, belly = j(11, 15), j(0.85, 1.1), (j(0.9, 1.25) if rng.random() < 0.7 else 0.0)
    else:
        stick = rng.random() < 0.3
        head_r = j(6.5, 10)
        arm_r = j(1.2, 2.2) if stick else j(2.2, 3.8)
        leg_r = j(1.6, 2.8) if stick else j(3.0, 4.8)
        shoulder, torso_w, belly = j(8, 12), (j(0.35, 0.55) if stick else j(0.6, 0.85)), 0.0
    return Build(spine=j(26, 34), neck=j(3, 8), head_r=head_r, shoulder=shoulder, upper_arm=j(15, 20),
                 forearm=j(14, 18), arm_r=arm_r, hip=j(4.5, 8), thigh=j(20, 27), shin=j(19, 25), leg_r=leg_r,
                 foot=j(7, 11), torso_w=torso_w, torso_d=j(0.55, 0.85), belly=belly,
                 skirt=j(0.45, 1.0) if rng.random() < 0.25 else 0.0, sleeves=float(rng.choice([0.0, 0.5, 1.0])),
                 trousers=float(rng.choice([0.0, 0.5, 1.0, 1.0])))


def person_pose(rng: np.random.Generator, b: Build, motion: Motion | None = None, frame: int = 0) -> tuple[
        np.ndarray, str]:
    """(19, 3) joints of a person (HUMAN order), from a BVH frame's bone directions when `motion` is given,
    else procedural; and the name of the motion."""
    lengths = _person_lengths(b)
    if motion is not None:
        src = humanoid_joints(motion, frame, canonical_frame(motion))
        dirs = {}
        for c, p in enumerate(HUMAN_PARENTS):
            if p < 0 or HUMAN[c] == "hip":
                continue
            pn, cn = HUMAN[p], HUMAN[c]
            if pn == "hip":
                pn = "root"
            if cn == "head" and "head" in src and "neck" in src:
                dirs[c] = unit(src["head"] - src["neck"])
            elif pn in src and cn in src and np.linalg.norm(src[cn] - src[pn]) > 1e-6:
                dirs[c] = unit(src[cn] - src[pn])
        if len(dirs) >= 14:
            return _chain(dirs, lengths), "bvh"
    return _procedural_person(rng, b, lengths), "procedural"


def _person_lengths(b: Build) -> dict[int, float]:
    """Bone length per child joint of HUMAN (the hip bone has none: AnimatedDrawings' root = hip)."""
    return {1: 0.0, 2: b.spine, 3: b.neck, 4: 2 * b.head_r, 5: b.shoulder, 6: b.upper_arm, 7: b.forearm, 8: b.shoulder,
            9: b.upper_arm, 10: b.forearm, 11: b.hip, 12: b.thigh, 13: b.shin, 14: b.foot, 15: b.hip, 16: b.thigh,
            17: b.shin, 18: b.foot}


def _chain(dirs: dict[int, np.ndarray], lengths: dict[int, float]) -> np.ndarray:
    """(19, 3) joints from unit bone directions per child joint (missing: the parent bone's) and lengths."""
    out = np.zeros((len(HUMAN), 3))
    for c, p in enumerate(HUMAN_PARENTS):
        if p < 0:
            continue
        d = dirs.get(c)
        if d is None:
            d = unit(out[p] - out[HUMAN_PARENTS[p]]) if HUMAN_PARENTS[p] >= 0 else UP
        out[c] = out[p] + lengths[c] * d
    return out


def _procedural_person(rng: np.random.Generator, b: Build, lengths: dict[int, float]) -> np.ndarray:
    """A random pose: standing, walking, reaching across the body, crossing the legs or sitting."""
    mode = rng.choice(["stand", "walk", "reach", "cross_legs", "sit", "wild"], p=[0.2, 0.22, 0.22, 0.12, 0.1, 0.14])
    n = lambda s: float(rng.normal(0, s))  # noqa: E731
    twist = n(12)
    spine = rotate(rotate(UP, LEFT, n(8) + (12 if mode == "sit" else 0)), FORWARD, n(6))
    body = np.stack([rotate(LEFT, UP, twist), spine, rotate(FORWARD, UP, twist)])  # shoulders' frame
    hips = np.stack([rotate(LEFT, UP, 0.4 * twist), UP, rotate(FORWARD, UP, 0.4 * twist)])
    dirs: dict[int, np.ndarray] = {2: spine, 3: unit(spine + 0.15 * rng.normal(0, 1, 3)),
                                   4: unit(spine + 0.25 * rng.normal(0, 1, 3))}
    for (s, e, h), sign in (((5, 6, 7), -1), ((8, 9, 10), 1)):
        dirs[s] = unit(sign * body[0] - 0.15 * body[1])
        down, az = rng.uniform(5, 75), sign * rng.uniform(-30, 100)
        if mode == "wild":
            down, az = rng.uniform(0, 170), rng.uniform(-180, 180)
        if mode == "walk":
            down, az = rng.uniform(5, 35), rng.choice([0.0, 180.0]) + n(20)
        upper = direction(down, az, body)
        flex = rng.uniform(0, 120) if mode != "stand" else rng.uniform(0, 40)
        bend_axis = np.cross(upper, body[2] if rng.random() < 0.8 else -body[2])
        dirs[e], dirs[h] = upper, unit(rotate(upper, bend_axis, flex))
    phase = rng.uniform(0, 2 * math.pi)  # of the walk: the legs swing in opposition
    for (hp, k, f, t), sign in (((11, 12, 13, 14), -1), ((15, 16, 17, 18), 1)):
        dirs[hp] = unit(sign * hips[0] - 0.3 * UP)
        swing, spread, knee = n(12), sign * rng.uniform(-4, 14), rng.uniform(0, 25)
        if mode == "walk":
            swing, knee = 28 * math.sin(phase) * -sign, rng.uniform(5, 60)
        if mode == "sit":
            swing, knee = rng.uniform(60, 95), rng.uniform(60, 100)
        if mode == "wild":
            swing, spread, knee = rng.uniform(-40, 100), sign * rng.uniform(-20, 50), rng.uniform(0, 120)
        thigh = rotate(rotate(-UP, LEFT, -swing), FORWARD, -spread)  # swing forward, spread outward
        dirs[k] = thigh
        dirs[f] = unit(rotate(thigh, np.cross(thigh, FORWARD), -knee))  # the knee bends backward
        dirs[t] = unit(0.3 * dirs[f] + FORWARD + 0.1 * rng.normal(0, 1, 3))
    pose = _chain(dirs, lengths)
    if mode == "reach":
        _reach_across(rng, pose, b, body)
    if mode == "cross_legs":
        _cross_legs(rng, pose, b)
    return pose


def _reach_across(rng: np.random.Generator, pose: np.ndarray, b: Build, body: np.ndarray) -> None:
    """One hand across the torso, in front of it (mostly) or behind it (IK in place)."""
    side = int(rng.integers(2))
    s, e, h = (5, 6, 7) if side == 0 else (8, 9, 10)
    sign = -1 if side == 0 else 1
    depth = b.shoulder * b.torso_d * (b.belly + 1.0) + b.arm_r
    front = rng.random() < 0.75
    target = (pose[0] + body[1] * rng.uniform(0.25, 0.9) * b.spine - sign * body[0] * rng.uniform(-0.2, 1.0) * b.shoulder
              + body[2] * (depth * rng.uniform(1.0, 1.6) if front else -depth * rng.uniform(1.0, 1.5)))
    pole = unit(sign * body[0] * 1.0 + (-body[2] if front else body[2]) * 0.3 - body[1] * 0.5)
    pose[e], pose[h] = two_bone_ik(pose[s], target, b.upper_arm, b.forearm, pole)


def _cross_legs(rng: np.random.Generator, pose: np.ndarray, b: Build) -> None:
    """The shins (or whole legs) cross, one leg in front: the feet swapped past each other."""
    front_right = rng.random() < 0.5
    for hp, k, f, t, sign in ((11, 12, 13, 14, -1), (15, 16, 17, 18, 1)):
        in_front = (sign < 0) == front_right
        foot = pose[0] - UP * (b.thigh + b.shin) * rng.uniform(0.8, 0.95) \
            + LEFT * (-sign) * rng.uniform(0.3, 1.2) * b.hip + FORWARD * (b.leg_r * (1.2 if in_front else -0.8))
        pose[k], pose[f] = two_bone_ik(pose[hp], foot, b.thigh, b.shin, unit(FORWARD + 0.2 * LEFT * sign))
        pose[t] = pose[f] + b.foot * unit(FORWARD + 0.3 * LEFT * -sign - 0.3 * UP)


def person_body(rng: np.random.Generator, family: str, motion: Motion | None = None, frame: int = 0) -> Body:
    """A person of the round, thin or props family, posed; its solids and marks."""
    b = person_build(rng, family)
    pose, source = person_pose(rng, b, motion, frame)
    body = Body(family, list(HUMAN), list(HUMAN_PARENTS), pose, ad_joints=AD_HUMAN, motion=source)
    hand = (7 if rng.random() < 0.5 else 10) if family == "props" else None
    if hand is not None and rng.random() < 0.5:  # the prop held out in front of the body, where it covers it
        p = body.pose
        fwd = unit(np.cross(unit(p[8] - p[5]), unit(p[2] - p[0])))
        target = p[0] + UP * rng.uniform(0.2, 0.9) * b.spine + fwd * rng.uniform(1.2, 2.2) * b.shoulder \
            + LEFT * rng.uniform(-0.8, 0.8) * b.shoulder
        p[hand - 1], p[hand] = two_bone_ik(p[hand - 2], target, b.upper_arm, b.forearm, -UP)
    _dress_person(rng, body, b)
    if hand is not None:
        _hold_prop(rng, body, b, hand)
    return body


def _dress_person(rng: np.random.Generator, body: Body, b: Build) -> None:
    """The person's solids: torso (and belly, hips), neck, head (with hair, nose, ears), limbs, hands, feet."""
    p = body.pose
    sol = body.solids
    spine = unit(p[2] - p[0])
    left = unit(p[8] - p[5])
    fwd = unit(np.cross(left, spine))
    axes = np.stack([spine, left, fwd])
    half = 0.5 * b.spine + 0.12 * b.spine
    wide = b.shoulder * b.torso_w
    top = "top"
    sol.append(ellipsoid(p[0] + spine * 0.5 * b.spine, axes, (half, wide, wide * b.torso_d), 2, top, "torso"))
    hips_w = max(b.hip + b.leg_r, 0.75 * wide)
    legs = "trousers" if b.trousers > 0 else "skin"
    sol.append(ellipsoid(p[0] - spine * 0.1 * b.spine, axes, (0.32 * b.spine, hips_w, hips_w * 0.75), 2,
                         "trousers" if b.trousers > 0 else top, "hips"))
    if b.belly:
        r = b.belly * wide
        patch = (np.array([0.0, 0.0, 1.0]), math.cos(math.radians(rng.uniform(35, 60))), "belly") \
            if rng.random() < 0.4 else None
        sol.append(ellipsoid(p[0] + spine * 0.35 * b.spine + fwd * 0.25 * r, axes, (0.45 * b.spine, r, r * 0.9), 2,
                             top, "belly", patch=patch))
        body.marks.append(Mark("spot", (sol[-1].centre + fwd * r * 0.9)[None], 0.6, len(sol) - 1))
    elif rng.random() < 0.4:  # buttons down the front
        front = sol[0]
        for t in np.linspace(-0.5, 0.6, int(rng.integers(2, 5))):
            body.marks.append(Mark("spot", on_ellipsoid(front, np.array([t, 0.0, 1.0]))[None], 0.7, 0))
    sol.append(limb(p[2], p[3] + spine * 0.3 * b.head_r, 0.35 * b.head_r, 0.33 * b.head_r, 3, "skin", "neck"))
    head_c = p[3] + unit(p[4] - p[3]) * b.head_r
    head_axes = frame_along(unit(p[4] - p[3]), fwd)
    head_axes = np.stack([head_axes[0], np.cross(head_axes[1], head_axes[0]), head_axes[1]])  # up, left, fwd
    hr = (b.head_r * rng.uniform(1.0, 1.15), b.head_r * rng.uniform(0.85, 1.0), b.head_r * rng.uniform(0.85, 1.0))
    sol.append(ellipsoid(head_c, head_axes, hr, 4, "skin", "head"))
    head = len(sol) - 1
    body.ad_moves["neck"] = head_c
    for s in (-1, 1):  # eyes
        body.marks.append(Mark("spot", on_ellipsoid(sol[head], np.array([0.2, 0.35 * s, 1.0]))[None], 0.08 * b.head_r,
                               head))
    mouth = np.array([on_ellipsoid(sol[head], np.array([-0.35 + 0.08 * abs(v), v, 1.0])) for v in np.linspace(-.35, .35, 7)])
    body.marks.append(Mark("curve", mouth, 0.05 * b.head_r, head))
    if rng.random() < 0.6:  # hair: a cap over the top and back of the head
        sol.append(ellipsoid(head_c + head_axes[0] * 0.25 * b.head_r - head_axes[2] * 0.12 * b.head_r, head_axes,
                             (hr[0] * 0.85, hr[1] * 1.06, hr[2] * 1.02), 4, "hair", "hair"))
    if rng.random() < 0.3:
        sol.append(ellipsoid(on_ellipsoid(sol[head], np.array([0.0, 0.0, 1.0])), head_axes,
                             (0.2 * b.head_r, 0.14 * b.head_r, 0.18 * b.head_r), 4, "skin", "nose"))
    for s, e, h in ((5, 6, 7), (8, 9, 10)):
        mat_u = top if b.sleeves > 0 else "skin"
        mat_f = top if b.sleeves >= 1 else "skin"
        sol.append(limb(p[s], p[e], b.arm_r * 1.1, b.arm_r, e, mat_u, HUMAN[e]))
        if rng.random() < 0.25:  # stripes round the upper arm
            for t in rng.uniform(0.3, 0.8, int(rng.integers(1, 3))):
                c = p[s] + t * (p[e] - p[s])
                body.marks.append(Mark("curve", ring(c, p[e] - p[s], b.arm_r * 1.05), 0.35, len(sol) - 1))
        sol.append(limb(p[e], p[h], b.arm_r, b.arm_r * 0.85, h, mat_f, HUMAN[h]))
        sol.append(ellipsoid(p[h] + unit(p[h] - p[e]) * b.arm_r * 0.9, frame_along(p[h] - p[e]),
                             (b.arm_r * 1.4, b.arm_r * 1.1, b.arm_r * 0.7), h, "skin", HUMAN[h].replace("hand", "palm")))
    for hp, k, f, t in ((11, 12, 13, 14), (15, 16, 17, 18)):
        mat_t = legs
        mat_s = "trousers" if b.trousers >= 1 else "skin"
        sol.append(limb(p[hp], p[k], b.leg_r * 1.15, b.leg_r, k, mat_t, HUMAN[k].replace("knee", "thigh")))
        sol.append(limb(p[k], p[f], b.leg_r, b.leg_r * 0.8, f, mat_s, HUMAN[f].replace("foot", "shin")))
        toe = unit(p[t] - p[f])
        sol.append(ellipsoid(p[f] + toe * 0.45 * b.foot - UP * 0.2 * b.leg_r, frame_along(toe, UP),
                             (0.6 * b.foot, 0.5 * b.leg_r + 1.0, 0.75 * b.leg_r + 0.8), t, "boots", HUMAN[t]))
    if b.skirt:
        waist = p[0] + spine * 0.05 * b.spine
        sol.append(limb(waist, waist - UP * b.skirt * b.thigh * 1.1, hips_w * 1.05, hips_w * rng.uniform(1.3, 1.9), 2,
                        "skirt", "skirt"))


def _hold_prop(rng: np.random.Generator, body: Body, b: Build, hand: int) -> None:
    """A prop in one hand, on a bone from the hand to the prop: a stick, a ball, a box or a bag."""
    p = body.pose
    kind = rng.choice(["stick", "ball", "box", "bag"])
    out = unit(p[hand] - p[hand - 1])
    palm = p[hand] + out * b.arm_r * 1.2
    j = len(body.joints)
    body.joints.append("prop")
    body.parents.append(hand)
    size = rng.uniform(0.7, 1.3)
    if kind == "stick":
        d = unit(rng.normal(0, 1, 3) + out)
        end = palm + d * rng.uniform(25, 45) * size
        body.solids.append(limb(palm - d * 6 * size, end, rng.uniform(0.8, 1.8), rng.uniform(0.8, 1.8), j, "prop",
                                "stick"))
    elif kind == "ball":
        r = rng.uniform(5, 11) * size
        end = palm + out * r
        body.solids.append(ellipsoid(end, np.eye(3), (r, r, r), j, "prop", "ball"))
    elif kind == "box":
        half = np.array([rng.uniform(4, 10), rng.uniform(4, 9), rng.uniform(1.5, 6)]) * size
        end = palm + out * half[0]
        axes = frame_along(out, rng.normal(0, 1, 3))
        body.solids.append(ellipsoid(end, axes, half, j, "prop", "box", kind="box"))
    else:
        r = rng.uniform(5, 9) * size
        end = palm - UP * (r * 1.4)
        body.solids.append(limb(palm, palm - UP * 3, 0.6, 0.6, j, "prop", "strap"))
        body.solids.append(ellipsoid(end, np.stack([UP, LEFT, FORWARD]), (r * 1.1, r, r * 0.5), j, "prop", "bag"))
    body.pose = np.vstack([p, end[None]])
    body.ad_joints = tuple(body.ad_joints) + ("prop",)


# ----------------------------------------------------------------------------- quadrupeds

QUAD = ["root", "hip", "torso", "neck", "head", "right_hip_f", "right_knee_f", "right_foot_f", "left_hip_f",
        "left_knee_f", "left_foot_f", "right_hip_b", "right_knee_b", "right_foot_b", "left_hip_b", "left_knee_b",
        "left_foot_b", "tail1", "tail2", "tail3"]
QUAD_PARENTS = [-1, 0, 1, 2, 3, 2, 5, 6, 2, 8, 9, 0, 11, 12, 0, 14, 15, 0, 17, 18]
AD_QUAD = ("root", "hip", "torso", "neck", "right_hip_b", "right_knee_b", "right_foot_b", "left_hip_b", "left_knee_b",
           "left_foot_b", "right_hip_f", "right_knee_f", "right_foot_f", "left_hip_f", "left_knee_f", "left_foot_f")


def quadruped_body(rng: np.random.Generator) -> Body:
    """A pig, dog, horse or cat in a walk, trot, stand or sit, head and tail anywhere."""
    j = lambda lo, hi: float(rng.uniform(lo, hi))  # noqa: E731
    kind = rng.choice(["pig", "dog", "horse", "cat"])
    length = {"pig": j(30, 40), "dog": j(28, 38), "horse": j(38, 48), "cat": j(24, 32)}[kind]
    girth = {"pig": j(11, 16), "dog": j(7, 10), "horse": j(9, 12), "cat": j(6, 8.5)}[kind]
    leg = {"pig": j(10, 15), "dog": j(16, 22), "horse": j(26, 34), "cat": j(13, 18)}[kind]
    leg_r = {"pig": j(2.8, 4.5), "dog": j(1.8, 3.0), "horse": j(2.2, 3.4), "cat": j(1.4, 2.4)}[kind]
    head_r = {"pig": j(8, 11), "dog": j(6, 8.5), "horse": j(6, 8), "cat": j(5.5, 7.5)}[kind]
    tail_r = {"pig": j(0.8, 1.4), "dog": j(1.5, 3.0), "horse": j(2.0, 3.2), "cat": j(1.3, 2.2)}[kind]
    tail_len = {"pig": j(3, 5), "dog": j(6, 10), "horse": j(8, 12), "cat": j(8, 12)}[kind]
    pose = np.zeros((len(QUAD), 3))
    pitch = rng.normal(0, 6)
    spine = rotate(FORWARD, LEFT, -pitch)
    pose[2] = pose[0] + spine * length
    neck_dir = unit(rotate(spine, LEFT, -rng.uniform(10, 70)) + 0.3 * LEFT * rng.normal(0, 1))
    pose[3] = pose[2] + neck_dir * girth * (0.6 if kind == "pig" else 1.1)
    head_dir = unit(rotate(neck_dir, LEFT, rng.uniform(20, 80)) + 0.4 * LEFT * rng.normal(0, 1))
    pose[4] = pose[3] + head_dir * head_r * 2.2
    gait = rng.choice(["walk", "trot", "stand", "sit", "gallop"], p=[0.35, 0.2, 0.2, 0.1, 0.15])
    phase0 = rng.uniform(0, 2 * math.pi)
    offsets = {"walk": (0.0, 0.5, 0.75, 0.25), "trot": (0.0, 0.5, 0.5, 0.0), "gallop": (0.0, 0.1, 0.6, 0.7),
               "stand": (0, 0, 0, 0), "sit": (0, 0, 0, 0)}[gait]
    amp = {"walk": 22, "trot": 30, "gallop": 45, "stand": 6, "sit": 6}[gait]
    for k, (hp, root, side) in enumerate(((5, 2, -1), (8, 2, 1), (11, 0, -1), (14, 0, 1))):
        pose[hp] = pose[root] + LEFT * side * girth * 0.55 - UP * girth * 0.35
        swing = amp * math.sin(phase0 + 2 * math.pi * offsets[k]) + rng.normal(0, 5)
        if gait == "sit" and root == 0:
            swing = rng.uniform(60, 90)
        thigh = rotate(-UP, LEFT, -swing)
        bend = rng.uniform(0, 50) if math.cos(phase0 + 2 * math.pi * offsets[k]) > 0 else rng.uniform(0, 15)
        bend = bend if root == 2 else -bend  # fore knees bend back, hocks forward
        pose[hp + 1] = pose[hp] + thigh * leg * 0.5
        pose[hp + 2] = pose[hp + 1] + rotate(thigh, LEFT, bend) * leg * 0.5
    tail = unit(-spine + UP * rng.uniform(-0.8, 1.2) + LEFT * rng.normal(0, 0.4))
    curl = rng.normal(0, 35)
    pose[17] = pose[0] - spine * girth * 0.8
    for t in (18, 19):
        tail = unit(rotate(tail, LEFT, curl) + LEFT * rng.normal(0, 0.2))
        pose[t] = pose[t - 1] + tail * tail_len
    body = Body("quadruped", list(QUAD), list(QUAD_PARENTS), pose, ad_joints=AD_QUAD)
    sol = body.solids
    axes = frame_along(spine, UP)
    axes = np.stack([axes[0], np.cross(axes[1], axes[0]), axes[1]])  # along, left, up
    belly = (np.array([0.0, 0.0, -1.0]), math.cos(math.radians(rng.uniform(30, 55))), "belly") \
        if rng.random() < 0.35 else None
    sol.append(ellipsoid(pose[0] + spine * 0.5 * length, axes, (0.5 * length + 0.7 * girth, girth, girth * j(0.85, 1.1)),
                         2, "body", "body", patch=belly))
    sol.append(limb(pose[2], pose[3], girth * 0.55, head_r * 0.7, 3, "body", "neck"))
    head_axes = frame_along(head_dir, UP)
    sol.append(ellipsoid(pose[3] + head_dir * head_r, head_axes, (head_r * 1.15, head_r, head_r * 0.95), 4, "body",
                         "head"))
    head = len(sol) - 1
    body.ad_moves["neck"] = sol[head].centre
    snout = {"pig": 0.55, "dog": 0.9, "horse": 1.3, "cat": 0.35}[kind]
    tip = pose[3] + head_dir * head_r * (1.8 + snout)
    sol.append(limb(sol[head].centre + head_dir * head_r * 0.4, tip, head_r * 0.5, head_r * (0.45 if kind == "pig" else 0.3),
                    4, "body", "snout"))
    pose[4] = tip
    for s in (-1, 1):
        ear = sol[head].centre + UP * head_r * 0.8 + LEFT * s * head_r * 0.55
        sol.append(limb(ear - UP * head_r * 0.3, ear + unit(UP + LEFT * s * 0.3) * head_r * (0.9 if kind != "pig" else 0.6),
                        head_r * 0.3, head_r * 0.12, 4, "body", f"ear{s}"))
        body.marks.append(Mark("spot", on_ellipsoid(sol[head], np.array([0.45, 0.4 * s, 0.35]))[None], 0.08 * head_r,
                               head))
    for hp in (5, 8, 11, 14):
        front = hp < 11
        sol.append(limb(pose[hp] + UP * girth * 0.3, pose[hp + 1], leg_r * (1.9 if not front else 1.6), leg_r, hp + 1,
                        "body", QUAD[hp + 1].replace("knee", "upper_leg")))
        sol.append(limb(pose[hp + 1], pose[hp + 2], leg_r, leg_r * 0.85, hp + 2, "body", QUAD[hp + 2].replace("foot", "lower_leg")))
        sol.append(ellipsoid(pose[hp + 2] - UP * leg_r * 0.3 + spine * leg_r * 0.4, axes,
                             (leg_r * 1.4, leg_r * 1.1, leg_r * 0.7), hp + 2, "hoof" if kind in ("pig", "horse") else "body",
                             QUAD[hp + 2].replace("foot", "paw")))
    for t in (18, 19):
        sol.append(limb(pose[t - 1], pose[t], tail_r * (1.2 if t == 18 else 1.0), tail_r * (1.0 if t == 18 else 0.5), t,
                        "body", f"tail{t - 17}"))
    return body


# ----------------------------------------------------------------------------- tailed bipeds (held out)

CREATURE = ["root", "hip", "torso", "neck", "head", "right_shoulder", "right_elbow", "right_hand", "left_shoulder",
            "left_elbow", "left_hand", "right_hip", "right_knee", "right_foot", "right_toe", "left_hip", "left_knee",
            "left_foot", "left_toe", "tail1", "tail2", "tail3"]
CREATURE_PARENTS = [-1, 0, 1, 2, 3, 2, 5, 6, 2, 8, 9, 0, 11, 12, 13, 0, 15, 16, 17, 0, 19, 20]
AD_CREATURE = AD_HUMAN + ("tail1", "tail2", "tail3")


def creature_body(rng: np.random.Generator) -> Body:
    """A dinosaur, a bird or a kangaroo: a leaning body, round thighs, small arms, a neck, a head with a snout
    or beak, and a tail."""
    j = lambda lo, hi: float(rng.uniform(lo, hi))  # noqa: E731
    kind = rng.choice(["dino", "bird", "kangaroo"])
    lean = {"dino": j(40, 70), "bird": j(20, 50), "kangaroo": j(10, 35)}[kind]
    spine_len, girth = j(24, 34), j(9, 15)
    spine = rotate(UP, LEFT, lean)
    pose = np.zeros((len(CREATURE), 3))
    pose[2] = spine * spine_len
    neck_dir = unit(rotate(spine, LEFT, -rng.uniform(0, 50)))
    pose[3] = pose[2] + neck_dir * j(6, 16)
    head_r = j(5.5, 9)
    head_dir = unit(rotate(neck_dir, LEFT, rng.uniform(30, 90)) + LEFT * rng.normal(0, 0.3))
    pose[4] = pose[3] + head_dir * head_r * 2.5
    arm, leg = j(8, 14), j(22, 32)
    for s, e, h, side in ((5, 6, 7, -1), (8, 9, 10, 1)):
        pose[s] = pose[2] - spine * 4 + LEFT * side * girth * 0.6 + FORWARD * girth * 0.4
        d1 = direction(rng.uniform(20, 120), side * rng.uniform(-40, 80))
        pose[e] = pose[s] + d1 * arm * 0.5
        pose[h] = pose[e] + unit(rotate(d1, LEFT, rng.uniform(-90, 20))) * arm * 0.5
    walk = rng.uniform(0, 2 * math.pi)
    for hp, k, f, t, side in ((11, 12, 13, 14, -1), (15, 16, 17, 18, 1)):
        pose[hp] = pose[0] + LEFT * side * girth * 0.5
        swing = 30 * math.sin(walk + (0 if side < 0 else math.pi)) + rng.normal(0, 8)
        thigh = rotate(-UP, LEFT, -swing - 20)
        pose[k] = pose[hp] + thigh * leg * 0.45
        shin = rotate(thigh, LEFT, rng.uniform(30, 80))
        pose[f] = pose[k] + shin * leg * 0.55
        pose[t] = pose[f] + unit(FORWARD - UP * 0.2 + LEFT * side * 0.1) * j(4, 8)
    tail = unit(-spine * 0.6 - FORWARD * 0.6 + LEFT * rng.normal(0, 0.4))
    pose[19] = pose[0] - spine * girth * 0.3
    tail_len = {"dino": j(14, 20), "bird": j(5, 9), "kangaroo": j(12, 18)}[kind]
    for t in (20, 21):
        tail = unit(rotate(tail, LEFT, rng.normal(0, 25)) + LEFT * rng.normal(0, 0.25))
        pose[t] = pose[t - 1] + tail * tail_len
    body = Body("creature", list(CREATURE), list(CREATURE_PARENTS), pose, ad_joints=AD_CREATURE)
    sol = body.solids
    axes = frame_along(spine, FORWARD)
    axes = np.stack([axes[0], np.cross(axes[1], axes[0]), axes[1]])
    belly = (np.array([0.0, 0.0, 1.0]), math.cos(math.radians(j(30, 55))), "belly") if rng.random() < 0.5 else None
    sol.append(ellipsoid(pose[0] + spine * 0.45 * spine_len, axes, (0.5 * spine_len + 0.6 * girth, girth * 0.9, girth),
                         2, "body", "body", patch=belly))
    sol.append(limb(pose[2], pose[3], girth * 0.45, head_r * 0.6, 3, "body", "neck"))
    head_axes = frame_along(head_dir, UP)
    sol.append(ellipsoid(pose[3] + head_dir * head_r, head_axes, (head_r * 1.2, head_r, head_r * 0.9), 4, "body", "head"))
    head = len(sol) - 1
    body.ad_moves["neck"] = sol[head].centre
    beak = "beak" if kind == "bird" else "body"
    sol.append(limb(sol[head].centre + head_dir * head_r * 0.5, pose[4], head_r * (0.6 if kind != "bird" else 0.4),
                    head_r * (0.35 if kind != "bird" else 0.08), 4, beak, "snout"))
    for s in (-1, 1):
        body.marks.append(Mark("spot", on_ellipsoid(sol[head], np.array([0.3, 0.55 * s, 0.5]))[None], 0.09 * head_r,
                               head))
    arm_r = j(1.5, 3.0)
    for s, e, h in ((5, 6, 7), (8, 9, 10)):
        sol.append(limb(pose[s], pose[e], arm_r * 1.2, arm_r, e, "body", CREATURE[e]))
        sol.append(limb(pose[e], pose[h], arm_r, arm_r * 0.7, h, "body", CREATURE[h]))
    leg_r = j(2.5, 4.5)
    for hp, k, f, t in ((11, 12, 13, 14), (15, 16, 17, 18)):
        d = unit(pose[k] - pose[hp])
        sol.append(ellipsoid(pose[hp] + d * leg * 0.22, frame_along(d, FORWARD), (leg * 0.3, leg_r * 2.2, leg_r * 2.4), k,
                             "body", CREATURE[k].replace("knee", "thigh")))
        sol.append(limb(pose[k], pose[f], leg_r, leg_r * 0.7, f, "body", CREATURE[f].replace("foot", "shin")))
        sol.append(limb(pose[f], pose[t], leg_r * 0.8, leg_r * 0.5, t, "feet" if kind == "bird" else "body",
                        CREATURE[t]))
    tr = girth * 0.55
    for t in (20, 21):
        sol.append(limb(pose[t - 1], pose[t], tr, tr * 0.55, t, "body", f"tail{t - 19}"))
        tr *= 0.55
    return body


def make_body(rng: np.random.Generator, family: str, motion: Motion | None = None, frame: int = 0) -> Body:
    """A random posed body of a family (FAMILIES); people may take their pose from a BVH clip's frame."""
    if family in ("round", "thin", "props"):
        return person_body(rng, family, motion, frame)
    if family == "quadruped":
        return quadruped_body(rng)
    if family == "creature":
        return creature_body(rng)
    raise ValueError(f"body family {family!r}: use one of {FAMILIES}")
