"""The held-out redrawn set: two-key shots of the 3D generator holding what third-party drawings hold.

Our method holds where the skeleton explains the part shapes; real artists redraw. Every shot of this set is one
kind of motion, its keys redrawn (redraw.py: per solid +-20 % aspect, another outline, another shaky hand; the
in-betweens interpolate them) or, for a control, rigid (amount 0, the same body, camera, look and motion as the
redrawn shot it follows: its rigid twin):
- side_walk: a person or a tailed creature seen from the side takes one step: at key0 the near leg passes the far
  one (bent, over it), between the keys they part to a stride, at key1 the far leg passes behind the near one;
- arm_over_belly: a round person with a belly, or a creature (its arms made longer, CREATURE_ARMS): the near
  forearm lies across the belly at one key and is lifted off it (waving or held out) at the other;
- fold_arms: a person without a belly: the forearms folded into an X in front of the chest at one key (torso, one
  forearm, the other over it: three depths in one place) and unfolded (hanging or held open) at the other.
The generator checks what each kind promises on the exact per-bone shapes and depths of the render (render3d),
and draws again (another attempt) where it does not hold: check_side_walk, check_arm_over_belly,
check_fold_arms, and for redrawn keys the silhouette change (shots3d.redraw_iou). What it measured goes to
heldout.json (`checks`).

Seeds: the test split (occlusion3d.sample_seed('test', REDRAWN_INDEX_BASE + plan entry)) on a random stream of
their own (STREAM), so neither training, tuning nor the default held-out set drew one of these characters.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .bodies3d import UP, Body, make_body, rotate, unit
from .looks3d import make_look3d
from .occlusion3d import sample_seed
from .redraw import draw_redraw
from .render3d import make_camera
from .shots3d import (
    MAX_TRIES,
    REDRAW_IOU,
    REDRAW_STREAM,
    SHOT_FRAMES,
    Drawn,
    Shot3D,
    arm_turns,
    draw_motion,
    place,
    posed,
    redraw_iou,
    redrawn_motion,
    turn_between,
)

REDRAWN_INDEX_BASE = 2_000_000  # test-split indices past the default set's (1 000 000 + i)
STREAM = 47
KINDS = ("side_walk", "arm_over_belly", "fold_arms")
# (body family, style family, kind, redraw amounts): an entry with amounts (a, 0.0) is a redrawn shot and its
# rigid twin. Creature and crayon are held out of the occlusion network's training.
REDRAWN_PLAN = (
    ("thin", "ink", "side_walk", (1.0, 0.0)),
    ("creature", "crayon", "side_walk", (1.0,)),
    ("round", "no_outline", "side_walk", (0.5,)),
    ("round", "flat", "arm_over_belly", (1.0, 0.0)),
    ("creature", "flat", "arm_over_belly", (1.0,)),
    ("thin", "pencil", "fold_arms", (1.0,)),
    ("thin", "ink", "fold_arms", (1.0,)),
    ("thin", "watercolour", "fold_arms", (0.5,)),
    ("creature", "colour_lines", "side_walk", (1.0,)),
)
VIEWS = {"side_walk": ("side",), "arm_over_belly": ("front", "three_quarter"), "fold_arms": ("front", "three_quarter"),
         ("arm_over_belly", "creature"): ("three_quarter",)}  # from the front a creature's arm never leaves its body
FAMILIES = {"side_walk": ("thin", "round", "creature"), "arm_over_belly": ("round", "creature"),
            "fold_arms": ("thin", "round")}
# the promises, in pixels at 256 px (scaled by the area for other sizes)
LEG_OVERLAP_PX = 60  # at each key, the legs overlap below the higher knee by at least this
LEG_APART = 0.5  # ... and at mid-step by at most this share of the smaller key's overlap
ARM_OVER_PX = 40  # the forearm over the belly at its key
ARM_OFF = 0.25  # ... and over it at the other key by at most this share of that
FOLD_PX = 60  # torso and both forearms in one place at the folded key
FOLD_APART_PX = 12  # the forearms overlap by at most this at the unfolded key
FRONT = 0.8  # the share of an overlap on which the promised part is in front
CREATURE_ARMS = (1.8, 1.4)  # a creature's arms, longer and thicker, to lie over its belly (length, girth)


# ----------------------------------------------------------------------------- posing helpers

def aim(body: Body, targets: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
    """Local turns (for shots3d.posed) pointing bone c (ending at joint c) along the world direction targets[c]
    (3,), along the shortest arc from where its parent's turn leaves it; bones without a target follow their
    parent."""
    par, rest = body.parents, body.pose
    world = [np.eye(3)] * len(par)
    local = {}
    for c, p in enumerate(par):
        if p < 0:
            continue
        if c in targets:
            r = world[p].T @ turn_between(world[p] @ (rest[c] - rest[p]), targets[c]) @ world[p]
            local[c] = r
            world[c] = world[p] @ r
        else:
            world[c] = world[p]
    return local


def _frame(body: Body) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body's up (root to torso), left (right to left shoulder, across up) and forward axes (3,)."""
    j = {n: i for i, n in enumerate(body.joints)}
    p = body.pose
    up = unit(p[j["torso"]] - p[j["root"]])
    left = p[j["left_shoulder"]] - p[j["right_shoulder"]]
    left = unit(left - up * (left @ up))
    return up, left, np.cross(left, up)


def _radius(body: Body, joint: str) -> float:
    """The largest radius of the limbs on the bone ending at `joint`."""
    b = body.joints.index(joint)
    return max(float(max(s.radii)) for s in body.solids if s.bone == b and s.kind == "limb")


def _clear(body: Body, names: tuple[str, ...], q: np.ndarray, margin: float) -> bool:
    """True when the point q (3,) lies outside every named ellipsoid by about `margin` or more."""
    for s in body.solids:
        if s.name in names and s.kind == "ellipsoid":
            m = s.axes / (np.asarray(s.radii) + margin)[:, None]
            if float(np.linalg.norm(m @ (q - s.centre))) < 1.0:
                return False
    return True


def _across(body: Body, names: tuple[str, ...], elbow: np.ndarray, way: np.ndarray, fwd: np.ndarray, length: float,
            radius: float, beneath: list[tuple[tuple[np.ndarray, np.ndarray], float]] = ()
            ) -> tuple[np.ndarray, np.ndarray] | None:
    """A forearm from `elbow` (3,) along `way` (3,), turned forward (fwd) no more than it takes to clear the named
    ellipsoids by its radius and to pass in front of the forearms beneath it ((elbow, hand), radius) by both
    radii: (elbow, hand); None when even a forearm held straight forward does not."""
    for f in np.linspace(0.0, 2.5, 26):
        hand = elbow + length * unit(way + fwd * f)
        pts = [elbow + a * (hand - elbow) for a in np.linspace(0.2, 1.0, 17)]
        if all(_clear(body, names, q, radius) for q in pts) and all(
                _in_front(q, *seg, radius + r, fwd) for q in pts for seg, r in beneath):
            return elbow, hand
    return None


def _beside(body: Body, names: tuple[str, ...], shoulder: np.ndarray, length: float, down: np.ndarray, out: np.ndarray,
            radius: float) -> np.ndarray:
    """An elbow (3,) `length` from the shoulder toward `down` (3,), turned along `out` (3,) no more than it takes
    to clear the named ellipsoids by `radius` (so the upper arm hangs beside or before a round body, not in it)."""
    for o in np.linspace(0.0, 2.0, 21):
        elbow = shoulder + length * unit(down + out * o)
        if _clear(body, names, elbow, radius):
            break
    return elbow


def _in_front(q: np.ndarray, a: np.ndarray, b: np.ndarray, gap: float, fwd: np.ndarray) -> bool:
    """True when the point q (3,) is at least `gap` in front (along fwd) of the segment from a to b wherever it
    lies within `gap` of it seen from the front, or farther than that from it sideways."""
    t = np.linspace(0.0, 1.0, 33)[:, None]
    c = a + t * (b - a)
    ahead = (q - c) @ fwd
    side = np.linalg.norm((q - c) - ahead[:, None] * fwd, axis=1)
    return bool(np.all((side >= gap) | (ahead >= gap)))


def _near_side(body: Body, depth: np.ndarray, part: str, rng: np.random.Generator) -> str:
    """'left' or 'right': the side whose `part` joint (shoulder, hip) is nearer the camera (depth: (3,) the
    camera's depth axis in world); a coin when both are about as near."""
    j = {n: i for i, n in enumerate(body.joints)}
    dl, dr = (float(depth @ body.pose[j[f"{s}_{part}"]]) for s in ("left", "right"))
    coin = "left" if rng.random() < 0.5 else "right"
    if abs(dl - dr) < 0.15 * float(np.linalg.norm(body.pose[j[f"left_{part}"]] - body.pose[j[f"right_{part}"]])):
        return coin
    return "left" if dl < dr else "right"


def _three(v0: float, v1: float, v2: float, t: np.ndarray) -> np.ndarray:
    """(T,) the parabola through (0, v0), (0.5, v1), (1, v2)."""
    return v0 * 2 * (t - 0.5) * (t - 1) - v1 * 4 * t * (t - 1) + v2 * 2 * t * (t - 0.5)


def _hips_left(body: Body) -> np.ndarray:
    """(3,) the level direction from the right hip to the left."""
    j = {n: i for i, n in enumerate(body.joints)}
    left = body.pose[j["left_hip"]] - body.pose[j["right_hip"]]
    return unit(left - UP * (left @ UP))


def _stand(body: Body, rng: np.random.Generator) -> dict[int, np.ndarray]:
    """Targets that stand a person's legs straight under the hips (a little apart, knees soft)."""
    j = {n: i for i, n in enumerate(body.joints)}
    left = _hips_left(body)
    out = {}
    for side, sign in (("right", -1), ("left", 1)):
        thigh = unit(rotate(-UP, left, -rng.uniform(-4, 8)) + sign * left * rng.uniform(0.0, 0.12))
        out[j[f"{side}_knee"]] = thigh
        out[j[f"{side}_foot"]] = rotate(thigh, left, rng.uniform(2, 10))
    return out


# ----------------------------------------------------------------------------- the motions

def side_walk(body: Body, depth: np.ndarray, rng: np.random.Generator, times: np.ndarray
              ) -> tuple[list[dict[int, np.ndarray]], dict]:
    """One step seen from the side: near leg passing (thigh forward, knee bent, over the far leg) -> stride
    (near leg forward, far leg back) -> far leg passing behind the near one; a person's arms swing against the
    legs. Per time (T,) the local turns, and what it holds (near side, angles)."""
    j = {n: i for i, n in enumerate(body.joints)}
    p = body.pose
    left = _hips_left(body)
    creature = body.family == "creature"
    lean, knee0 = (20.0, 45.0) if creature else (0.0, 3.0)  # a creature's thighs lean forward, its knees bend
    near = _near_side(body, depth, "hip", rng)
    far = "left" if near == "right" else "right"
    stride = rng.uniform(30, 40) if creature else rng.uniform(22, 32)  # short legs swing farther
    passing, bend = rng.uniform(12, 22), rng.uniform(40, 65)
    legs = {near: (_three(passing, stride, -4, times), _three(bend, 5, 4, times)),
            far: (_three(-4, -stride, passing, times), _three(4, 15, bend, times))}
    elbow = rng.uniform(15, 35)
    turns = []
    for i in range(len(times)):
        targets = {}
        for side, (thigh, knee) in legs.items():
            d = rotate(-UP, left, -(thigh[i] + lean))
            targets[j[f"{side}_knee"]] = d
            targets[j[f"{side}_foot"]] = rotate(d, left, knee0 + knee[i])
            targets[j[f"{side}_toe"]] = p[j[f"{side}_toe"]] - p[j[f"{side}_foot"]]  # the foot keeps its way
            if not creature:  # the arm swings against its own side's leg, the forearm bent forward
                upper = rotate(-UP, left, 0.8 * thigh[i])
                targets[j[f"{side}_elbow"]] = upper
                targets[j[f"{side}_hand"]] = rotate(upper, left, -elbow)
        turns.append(aim(body, targets))
    return turns, {"near_side": near, "stride_deg": round(stride, 1), "passing_knee_deg": round(bend, 1)}


def arm_over_belly(body: Body, depth: np.ndarray, rng: np.random.Generator, times: np.ndarray
                   ) -> tuple[list[dict[int, np.ndarray]], dict]:
    """The near arm's forearm lies over the belly at one key and is lifted off (waving or held out) at the
    other; the other arm hangs; a person stands. Per time (T,) the local turns, and what it holds."""
    j = {n: i for i, n in enumerate(body.joints)}
    p = body.pose
    up, left, fwd = _frame(body)
    side = _near_side(body, depth, "shoulder", rng)
    out = left if side == "left" else -left
    s, e, h = (j[f"{side}_{n}"] for n in ("shoulder", "elbow", "hand"))
    l1, l2 = float(np.linalg.norm(p[e] - p[s])), float(np.linalg.norm(p[h] - p[e]))
    arm_r = _radius(body, f"{side}_hand")
    belly = ("belly", "torso") if body.family != "creature" else ("body",)
    # the elbow down at the side, the forearm across the front of the belly
    elbow = _beside(body, belly, p[s], l1, -up + out * rng.uniform(0.05, 0.3) + fwd * rng.uniform(0.2, 0.5), out,
                    arm_r)
    over = _across(body, belly, elbow, -out - up * rng.uniform(0.0, 0.3), fwd, l2, arm_r)
    if over is None:
        return None, {}
    if rng.random() < 0.5:  # waving: the upper arm out, the forearm up
        elbow = p[s] + l1 * unit(out + rng.uniform(-0.2, 0.4) * up + rng.uniform(0.0, 0.5) * fwd)
        off = (elbow, elbow + l2 * unit(up + rng.uniform(0.1, 0.5) * out + rng.uniform(0.0, 0.4) * fwd))
    else:  # held out to the side and forward
        elbow = p[s] + l1 * unit(out * rng.uniform(0.6, 1.0) - up * rng.uniform(0.2, 0.6) + fwd * rng.uniform(0.2, 0.6))
        off = (elbow, elbow + l2 * unit(out * rng.uniform(0.4, 0.9) + fwd * rng.uniform(0.3, 0.9)))
    over_key = int(rng.integers(2))
    turns = arm_turns(body, side, *((over, off) if over_key == 0 else (off, over)), times)
    other = "left" if side == "right" else "right"
    o = j[f"{other}_shoulder"]
    hang_e = p[o] + l1 * unit(-up - out * rng.uniform(0.15, 0.4))
    hang = (hang_e, hang_e + l2 * unit(-up - out * rng.uniform(0.05, 0.3) + fwd * rng.uniform(0.0, 0.4)))
    turns |= arm_turns(body, other, hang, hang, times)
    stand = {} if body.family == "creature" else aim(body, _stand(body, rng))
    frames = [stand | {c: r[i] for c, r in turns.items()} for i in range(len(times))]
    return frames, {"near_side": side, "over_key": over_key}


def fold_arms(body: Body, depth: np.ndarray, rng: np.random.Generator, times: np.ndarray
              ) -> tuple[list[dict[int, np.ndarray]], dict]:
    """A person's forearms folded over the chest at one key and unfolded (hanging, or held open) at the other;
    the person stands. Folded: the elbows down before the chest, the forearms across it rising to the other arm,
    one close over the torso, the other in front of it (an X, three depths where they cross). Per time
    (T,) the local turns, and what it holds (which forearm is on top, which key is folded)."""
    j = {n: i for i, n in enumerate(body.joints)}
    p = body.pose
    up, left, fwd = _frame(body)
    top = "left" if rng.random() < 0.5 else "right"
    style = "hang" if rng.random() < 0.5 else "open"
    folded, opened = {}, {}
    for side in ("left", "right") if top == "right" else ("right", "left"):  # the one beneath first
        out = left if side == "left" else -left
        s, e, h = (j[f"{side}_{n}"] for n in ("shoulder", "elbow", "hand"))
        l1, l2 = float(np.linalg.norm(p[e] - p[s])), float(np.linalg.norm(p[h] - p[e]))
        r = _radius(body, f"{side}_hand")
        # the elbow forward of the chest (turned forward until it clears it; the top one until it is in front of
        # the other forearm), the forearm across
        down = -up + fwd * rng.uniform(0.2, 0.5) + out * rng.uniform(0, 0.2)
        elbow = _beside(body, ("torso", "belly"), p[s], l1, down, fwd, 1.5 * r)
        beneath = [(folded[x], _radius(body, f"{x}_hand")) for x in folded]
        base = unit(elbow - p[s])
        for (e0, h0), r0 in beneath:
            ahead = max(float(e0 @ fwd), float(h0 @ fwd)) + r + r0
            for o in np.linspace(0.0, 3.0, 31):
                elbow = p[s] + l1 * unit(base + fwd * o)
                if elbow @ fwd >= ahead:
                    break
        slope = rng.uniform(0.1, 0.4)  # both hands up toward the other arm: the forearms cross
        folded[side] = _across(body, ("torso", "belly"), elbow, -out + up * slope, fwd, l2, r, beneath)
        if folded[side] is None or (folded[side][1] - p[j["torso"]]) @ out > -r:
            return None, {}  # the hand must reach past the middle of the chest (by its radius)
        if style == "hang":
            elbow = p[s] + l1 * unit(-up + out * rng.uniform(0.1, 0.4))
            opened[side] = (elbow, elbow + l2 * unit(-up + out * rng.uniform(0.05, 0.3) + fwd * rng.uniform(0.1, 0.5)))
        else:
            elbow = p[s] + l1 * unit(-up + out * rng.uniform(0.2, 0.5) + fwd * rng.uniform(0.0, 0.3))
            opened[side] = (elbow, elbow + l2 * unit(fwd + out * rng.uniform(0.4, 1.0) + up * rng.uniform(-0.2, 0.3)))
    fold_key = int(rng.integers(2))
    turns = {}
    for side in ("left", "right"):
        ends = (folded[side], opened[side]) if fold_key == 0 else (opened[side], folded[side])
        turns |= arm_turns(body, side, *ends, times)
    stand = aim(body, _stand(body, rng))
    frames = [stand | {c: r[i] for c, r in turns.items()} for i in range(len(times))]
    return frames, {"top_forearm": top, "fold_key": fold_key, "unfolded": style}


MOTIONS = {"side_walk": side_walk, "arm_over_belly": arm_over_belly, "fold_arms": fold_arms}


# ----------------------------------------------------------------------------- the checks

def _front_share(drawn: Drawn, k: int, front: int, back: int, where: np.ndarray) -> float:
    """The share of `where` (H, W bool) on which bone `front` is entered before bone `back` in frame k."""
    a, b = drawn.entry[k][front][where], drawn.entry[k][back][where]
    ok = np.isfinite(a) & np.isfinite(b)
    return float((a[ok] < b[ok]).mean()) if ok.any() else 0.0


def _leg(drawn: Drawn, k: int, side: str) -> tuple[np.ndarray, np.ndarray]:
    """The thigh and shin (with the foot) of one side in frame k: (H, W) bool shape, float32 entry depth."""
    a, b = drawn.bone(f"{side}_knee"), drawn.bone(f"{side}_foot")
    return drawn.cover[k][a] | drawn.cover[k][b], np.minimum(drawn.entry[k][a], drawn.entry[k][b])


def check_side_walk(drawn: Drawn, info: dict, scale: float) -> dict | None:
    """At both keys the legs overlap below the higher knee by >= LEG_OVERLAP_PX, the near leg in front on
    FRONT of it; at mid-step by at most LEG_APART of the smaller key's. What it measured, or None."""
    near = info["near_side"]
    far = "left" if near == "right" else "right"
    knees = [drawn.joints.index(f"{s}_knee") for s in (near, far)]
    fg = drawn.coverage >= 0.5
    px, front = [], []
    for k in range(len(drawn.frames)):
        (a, ea), (b, eb) = _leg(drawn, k, near), _leg(drawn, k, far)
        both = a & b & fg[k]
        both[: int(math.ceil(drawn.poses[k, knees, 1].min())) + 1] = False
        px.append(int(both.sum()))
        ok = np.isfinite(ea[both]) & np.isfinite(eb[both])
        front.append(float((ea[both] < eb[both])[ok].mean()) if ok.any() else 0.0)
    keys, mid = min(px[0], px[-1]), px[len(px) // 2]
    if keys < LEG_OVERLAP_PX * scale or mid > LEG_APART * keys or min(front[0], front[-1]) < FRONT:
        return None
    return {"leg_overlap_px": px, "near_leg_front": [round(front[0], 3), round(front[-1], 3)]}


def check_arm_over_belly(drawn: Drawn, info: dict, scale: float) -> dict | None:
    """At its key the near forearm overlaps the torso by >= ARM_OVER_PX, in front on FRONT of it; at the other
    key by at most ARM_OFF of that."""
    fore, torso = drawn.bone(f"{info['near_side']}_hand"), drawn.bone("torso")
    fg = drawn.coverage >= 0.5
    over, off = (0, -1) if info["over_key"] == 0 else (-1, 0)
    on = drawn.cover[over][fore] & drawn.cover[over][torso] & fg[over]
    left = drawn.cover[off][fore] & drawn.cover[off][torso] & fg[off]
    front = _front_share(drawn, over, fore, torso, on)
    if on.sum() < ARM_OVER_PX * scale or left.sum() > ARM_OFF * on.sum() or front < FRONT:
        return None
    return {"forearm_on_belly_px": [int(on.sum()), int(left.sum())][:: 1 if over == 0 else -1],
            "forearm_front": round(front, 3)}


def check_fold_arms(drawn: Drawn, info: dict, scale: float) -> dict | None:
    """At the folded key torso and both forearms cover >= FOLD_PX pixels together, in depth order torso,
    under forearm, top forearm on FRONT of them; at the unfolded key the forearms overlap by <= FOLD_APART_PX."""
    top = info["top_forearm"]
    under = "left" if top == "right" else "right"
    a, b, t = drawn.bone(f"{top}_hand"), drawn.bone(f"{under}_hand"), drawn.bone("torso")
    fg = drawn.coverage >= 0.5
    fold, unfold = (0, -1) if info["fold_key"] == 0 else (-1, 0)
    c = drawn.cover[fold]
    three = c[a] & c[b] & c[t] & fg[fold]
    e = drawn.entry[fold]
    ea, eb, et = e[a][three], e[b][three], e[t][three]
    ok = np.isfinite(ea) & np.isfinite(eb) & np.isfinite(et)
    order = float(((ea < eb) & (eb < et))[ok].mean()) if ok.any() else 0.0
    apart = int((drawn.cover[unfold][a] & drawn.cover[unfold][b] & fg[unfold]).sum())
    if three.sum() < FOLD_PX * scale or order < FRONT or apart > FOLD_APART_PX * scale:
        return None
    return {"three_depths_px": int(three.sum()), "depth_order_share": round(order, 3), "unfolded_overlap_px": apart}


CHECKS = {"side_walk": check_side_walk, "arm_over_belly": check_arm_over_belly, "fold_arms": check_fold_arms}


# ----------------------------------------------------------------------------- the set

def redrawn_name(index: int, family: str, style: str, kind: str, amount: float) -> str:
    """The shot's directory name: what it holds."""
    return f"r{index:02d}_{family}_{style}_{kind}_{'redrawn' if amount else 'rigid'}"


def _has_belly(body: Body) -> bool:
    """A round body: a person with a belly, or a creature (its body is its belly)."""
    return body.family == "creature" or any(s.name == "belly" for s in body.solids)


def longer_arms(body: Body, length: float, girth: float) -> Body:
    """The body at rest with both arms `length` times as long and `girth` times as thick (a creature's arms
    are too short to lie over its belly): the elbows and hands move out along the arms, the limbs and hands on
    the arm's bones stretch with them."""
    j = {n: i for i, n in enumerate(body.joints)}
    pose, solids = body.pose.copy(), list(body.solids)
    for side in ("left", "right"):
        s, e, h = (j[f"{side}_{n}"] for n in ("shoulder", "elbow", "hand"))
        elbow = pose[s] + length * (pose[e] - pose[s])
        hand = elbow + length * (pose[h] - pose[e])
        moves = {e: (pose[s], pose[s], elbow), h: (pose[e], elbow, hand)}  # bone: its old start, new start, end
        for i, x in enumerate(solids):
            if x.bone not in moves:
                continue
            old, start, end = moves[x.bone]
            shift = lambda q: start + length * (q - old)  # noqa: E731
            solids[i] = replace(x, centre=shift(x.centre), radii=x.radii * girth,
                                c1=None if x.c1 is None else shift(x.c1))
        pose[e], pose[h] = elbow, hand
    return replace(body, pose=pose, solids=solids)


def make_redrawn3d(entry: int, size: tuple[int, int] = (256, 256), first: int = 0, family: str | None = None,
                   style: str | None = None, kind: str | None = None, amounts: tuple[float, ...] | None = None
                   ) -> list[Shot3D]:
    """The shots of REDRAWN_PLAN[entry] (its family, style, kind and amounts unless given), numbered from
    `first`: one per amount, all of one attempt (the same body, camera, look and motion), each passing its kind's
    checks and, when redrawn, the silhouette change. Deterministic per (entry, size, the overrides)."""
    f0, s0, k0, a0 = REDRAWN_PLAN[entry % len(REDRAWN_PLAN)]
    family, style, kind, amounts = family or f0, style or s0, kind or k0, a0 if amounts is None else amounts
    if kind not in KINDS or family not in FAMILIES[kind]:
        raise ValueError(f"redrawn shot {kind!r} of a {family!r} body: kinds {KINDS}, families {FAMILIES}")
    seed = sample_seed("test", REDRAWN_INDEX_BASE + entry)
    times = np.linspace(0.0, 1.0, SHOT_FRAMES)
    scale = size[0] * size[1] / 256.0 ** 2
    for attempt in range(MAX_TRIES):
        rng = np.random.default_rng([seed, attempt, STREAM])
        rest = make_body(rng, family)
        if kind in ("arm_over_belly", "fold_arms") and (kind == "arm_over_belly") != _has_belly(rest):
            continue  # a belly to lie over; none for folded arms to reach across (they cannot round one)
        if kind == "arm_over_belly" and family == "creature":
            rest = longer_arms(rest, CREATURE_ARMS[0], CREATURE_ARMS[1])
        views = VIEWS.get((kind, family), VIEWS[kind])
        camera = make_camera(rng, views[int(rng.integers(len(views)))])
        turns, info = MOTIONS[kind](rest, camera.rot[2], rng, times)
        if turns is None:
            continue  # no pose of this kind for this body
        project = place([posed(rest, tr) for tr in turns], camera, size, rng)
        if project is None:
            continue
        look = make_look3d(style, rng, scale=max(size) / 256.0)
        shots = []
        for n, amount in enumerate(amounts):
            rd = draw_redraw(np.random.default_rng([seed, attempt, REDRAW_STREAM]), rest.solids, amount, size,
                             look.wobble)
            drawn = draw_motion(redrawn_motion(rest, turns, times, rd), project, size, look, seed * 7 + attempt,
                                [rd.rewobble(float(t)) for t in times])
            if drawn.leaves_frame():
                break
            checks = CHECKS[kind](drawn, info, scale)
            if checks is None:
                break
            if amount:
                iou = redraw_iou(rest, turns, rd, project, size, look, seed * 7 + attempt, drawn.coverage[-1])
                if iou > 1 - REDRAW_IOU * amount:
                    break
                checks["redraw_iou"] = round(iou, 4)
            extra = {"set": "redrawn", "kind": kind, "redraw": amount, "plan_entry": entry, **info, "checks": checks}
            shots.append(Shot3D(drawn.frames, drawn.coverage, drawn.joints, drawn.parents, drawn.poses,
                                (drawn.over[0], drawn.over[-1]), family, style, kind, camera.view, first + n, seed,
                                attempt, name=redrawn_name(first + n, family, style, kind, amount), extra=extra,
                                key_parts=drawn.key_parts()))
        if len(shots) == len(amounts):
            names = [s.name for s in shots]
            for s in shots:
                s.extra["twins"] = [x for x in names if x != s.name]
            return shots
    raise RuntimeError(f"redrawn entry {entry} ({family}, {style}, {kind}): no shot kept its promises in "
                       f"{MAX_TRIES} tries")

