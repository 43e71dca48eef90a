"""Two-key in-betweening shots from the 3D generator: one body, one camera, one look, a motion, exact in-betweens.

A shot is the occlusion generator's character (bodies3d, looks3d, render3d) posed along a motion and drawn at
SHOT_FRAMES evenly spaced poses with the same look and render seed, so every frame is the same character drawn
the same way; the first and last drawings are the keys, all of them the ground truth. The motion is
- procedural (every family): the body's own random pose with bones turned about their parent joints over the
  shot (bodies move rigidly with their bones, children follow): a person reaches across the front of the
  torso or walks, a quadruped trots, a creature walks or sweeps its tail from one side to the other;
- or, for people when BVH clips are given, SHOT_FRAMES frames of a clip `step` frames apart (the body rebuilt
  from the same random draws at every frame, only its bone directions differ).
The camera scale and placement are fixed over the whole motion (the union of its extents). The skeleton is the
AnimatedDrawings-style subset (occlusion3d.reduce_skeleton), projected per frame: x, y px and depth
(larger = farther).

Seeds come from the test split (occlusion3d.sample_seed('test', SHOT_INDEX_BASE + i)) and a random stream of
their own (STREAM), so neither training nor tuning ever drew one of these characters.
"""
from __future__ import annotations

import json
import math
import shutil
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ops.shotio.load import MAX_MASK_FILES

from .bodies3d import LEFT, UP, Body, Mark, make_body, two_bone_ik, unit
from .bvh import Motion
from .looks3d import make_look3d
from .occlusion3d import (
    HELD_OUT_FAMILY,
    HELD_OUT_STYLE,
    MIN_EVIDENCE_PX,
    _merge,
    _motions,
    pair_truth,
    reduce_skeleton,
    sample_seed,
)
from .redraw import Redraw, draw_redraw, redrawn_body
from .render3d import Camera, Rendered, Rewobble, fit_to_frame, make_camera, render
from .solids import Solid, transformed
from .write import FORMAT, _dump, _write_png

SHOT_FRAMES = 9  # output frames, both keys included
SHOT_INDEX_BASE = 1_000_000  # test-split indices far past the occlusion benchmark's (it takes the first few)
STREAM = 41  # the shots' own random stream: at an equal seed they draw nothing the occlusion samples draw
REDRAW_STREAM = 43  # the redrawn keys' changes: their own stream, so the rigid shot's draws stay as they were
REDRAW_IOU = 0.06  # a redrawn key1's silhouette IoU with key0's shapes reposed to it: at most 1 - this * amount
MAX_TRIES = 40
FILL = (0.6, 0.85)  # share of the frame the whole motion's extent fills
# the default set: (body family, style family, motion); creature and crayon are held out of the network's
# training (occlusion3d.HELD_OUT_FAMILY / HELD_OUT_STYLE); reach and tail move a limb across the body
PLAN = (("round", "ink", "reach"), ("quadruped", "crayon", "trot"), ("thin", "flat", "walk"),
        ("creature", "watercolour", "tail"), ("props", "colour_lines", "reach"), ("creature", "crayon", "walk"),
        ("thin", "pencil", "reach"), ("round", "no_outline", "walk"))
MOTIONS = {"round": ("reach", "walk"), "thin": ("reach", "walk"), "props": ("reach", "walk"),
           "quadruped": ("trot",), "creature": ("walk", "tail")}


@dataclass
class Shot3D:
    """One shot's arrays: frames (T, H, W, 3) uint8 RGB; coverage (T, H, W) float32; joints, parents of the
    skeleton; poses (T, J, 3) float64 x, y px and depth; crossings per key: the sorted non-adjacent bone pairs
    (child joint names) overlapping by >= MIN_EVIDENCE_PX; and what it is (family, style, motion, view, seed).
    name: the directory name when not shot_name's default; extra: more of what it holds, for heldout.json;
    key_parts: per key (first, last frame) the drawn bones' shapes and entry depths (Drawn.cover, Drawn.entry),
    from which write_true_annotation paints the true occlusion regions."""

    frames: np.ndarray
    coverage: np.ndarray
    joints: list[str]
    parents: list[int]
    poses: np.ndarray
    crossings: tuple[list[str], list[str]]
    family: str
    style: str
    motion: str
    view: str
    index: int
    seed: int
    attempt: int
    name: str = ""
    extra: dict = field(default_factory=dict)
    key_parts: tuple = ()


def plan(index: int) -> tuple[str, str, str]:
    """(family, style, motion) of shot `index` (PLAN cycles)."""
    return PLAN[index % len(PLAN)]


# ----------------------------------------------------------------------------- rigid posing

def axis_rotation(axis: np.ndarray, deg: float) -> np.ndarray:
    """(3, 3) rotation by `deg` degrees about `axis`."""
    return Rotation.from_rotvec(unit(axis) * math.radians(deg)).as_matrix()


def turn_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3, 3) the smallest rotation taking direction a (3,) to direction b (3,)."""
    a, b = unit(a), unit(b)
    axis = np.cross(a, b)
    s, c = float(np.linalg.norm(axis)), float(np.clip(a @ b, -1, 1))
    if s < 1e-9:
        return np.eye(3) if c > 0 else axis_rotation(np.cross(a, LEFT if abs(a @ LEFT) < 0.9 else UP), 180.0)
    return Rotation.from_rotvec(axis / s * math.atan2(s, c)).as_matrix()


def posed(body: Body, local: dict[int, np.ndarray]) -> Body:
    """The body with bone c (the one ending at joint c) turned by the (3, 3) rotation local[c] about its parent
    joint, in its parent bone's turned frame; children follow. Joints, solids, marks and the AnimatedDrawings
    moves ride rigidly on their bones (a bone's bodies are the solids whose `bone` is c)."""
    rest, par = body.pose, body.parents
    if any(p >= c for c, p in enumerate(par)):
        raise ValueError("posed: parents must come before their children")
    world = [np.eye(3)] * len(par)
    new = rest.copy()
    for c, p in enumerate(par):
        if p >= 0:
            world[c] = world[p] @ local.get(c, np.eye(3))
            new[c] = new[p] + world[c] @ (rest[c] - rest[p])

    def move(c: int) -> tuple[np.ndarray, np.ndarray]:
        """Bone c's rigid motion x -> R x + t."""
        p = par[c]
        return (np.eye(3), np.zeros(3)) if p < 0 else (world[c], new[p] - world[c] @ rest[p])

    solids = [transformed(s, *_rt(move(s.bone))) for s in body.solids]
    marks = []
    for m in body.marks:
        r, t = move(body.solids[m.solid].bone)
        marks.append(Mark(m.kind, m.points @ r.T + t, m.width, m.solid))
    moves = {}
    for name, p in body.ad_moves.items():  # e.g. the neck at the head's centre: it rides on the joint's child bone
        j = body.joints.index(name)
        child = next((c for c, q in enumerate(par) if q == j), j)
        r, t = move(child)
        moves[name] = r @ np.asarray(p) + t
    return replace(body, pose=new, solids=solids, marks=marks, ad_moves=moves)


def _rt(rt: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, float, np.ndarray]:
    """(rotation, scale 1, shift) for solids.transformed."""
    return rt[0], 1.0, rt[1]


def _swing(times: np.ndarray, amp: float, phase: float) -> np.ndarray:
    """(T,) degrees of a half cycle over the shot: amp * cos(pi t + phase) (from +amp to -amp at phase 0)."""
    return amp * np.cos(math.pi * times + phase)


def _slerp(r1: np.ndarray, times: np.ndarray) -> list[np.ndarray]:
    """(T,) rotations from the identity at t = 0 to r1 (3, 3) at t = 1, along the shortest arc."""
    s = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([np.eye(3), r1])))
    return list(s(times).as_matrix())


def arm_turns(body: Body, side: str, start: tuple[np.ndarray, np.ndarray], end: tuple[np.ndarray, np.ndarray],
              times: np.ndarray) -> dict[int, list[np.ndarray]]:
    """Local turns (T of them per joint: the elbow's and the hand's) moving a person's or creature's `side`
    arm from start to end, each an (elbow, hand) pair of (3,) world positions at the rest body's shoulder: the
    upper arm and forearm turned along the shortest arcs from the one to the other."""
    j = {n: i for i, n in enumerate(body.joints)}
    s, e, h = (j[f"{side}_{n}"] for n in ("shoulder", "elbow", "hand"))
    p = body.pose
    key = {}
    for which, (elbow, hand) in (("start", start), ("end", end)):
        upper = turn_between(p[e] - p[s], elbow - p[s])
        fore = upper.T @ turn_between(upper @ (p[h] - p[e]), hand - elbow) @ upper
        key[which] = (upper, fore)
    turns = {}
    for c, k in ((e, 0), (h, 1)):  # from the start to the end, both given relative to the rest pose
        a, b = key["start"][k], key["end"][k]
        turns[c] = [a @ r for r in _slerp(a.T @ b, times)]
    return turns


def _per_frame(turns: dict[int, list[np.ndarray]], n: int) -> list[dict[int, np.ndarray]]:
    """{joint: T turns} as T {joint: turn}."""
    return [{c: r[i] for c, r in turns.items()} for i in range(n)]


def procedural_motion(body: Body, kind: str, rng: np.random.Generator, times: np.ndarray
                      ) -> tuple[list[Body], tuple[str, ...]]:
    """The body at each time (T,) of a procedural motion (procedural_turns), and the joints ending the bones
    that cross the body."""
    turns, moving = procedural_turns(body, kind, rng, times)
    return [posed(body, tr) for tr in turns], moving


def procedural_turns(body: Body, kind: str, rng: np.random.Generator, times: np.ndarray
                     ) -> tuple[list[dict[int, np.ndarray]], tuple[str, ...]]:
    """Per time (T,), the local turns of a procedural motion (for posed), and the joints ending the bones
    that cross the body (reach, tail): 'reach' (a person's hand from the side to across the front of the torso),
    'walk' (legs and arms swing in opposition), 'trot' (a quadruped's diagonal legs swing in pairs, head and
    tail follow), 'tail' (a creature's tail sweeps from one side to the other)."""
    j = {n: i for i, n in enumerate(body.joints)}
    turns: dict[int, list[np.ndarray]] = {}

    def about(c: str, axis: np.ndarray, deg: np.ndarray) -> None:
        turns[j[c]] = [axis_rotation(axis, float(d)) for d in deg]

    if kind == "reach":
        side = "right" if rng.random() < 0.5 else "left"
        other = "left" if side == "right" else "right"
        s, e, h = (j[f"{side}_{n}"] for n in ("shoulder", "elbow", "hand"))
        p = body.pose
        up = unit(p[j["torso"]] - p[j["root"]])
        across = unit(p[j[f"{other}_shoulder"]] - p[s])
        fwd = unit(np.cross(unit(p[j["left_shoulder"]] - p[j["right_shoulder"]]), up))
        l1, l2 = np.linalg.norm(p[e] - p[s]), np.linalg.norm(p[h] - p[e])
        # start: the arm hanging out to its side; end: the hand on the far side of the chest, in front of it
        start_elbow = p[s] + l1 * unit(-up - 0.35 * across + 0.15 * fwd)
        start_hand = start_elbow + l2 * unit(-up - 0.2 * across + 0.3 * fwd)
        reach = float(np.linalg.norm(p[j[f"{other}_shoulder"]] - p[s]))
        target = p[s] + across * reach * rng.uniform(0.7, 1.0) - up * l1 * rng.uniform(0.3, 0.8) \
            + fwd * (l1 + l2) * rng.uniform(0.45, 0.6)
        end_elbow, end_hand = two_bone_ik(p[s], target, l1, l2, unit(-up - 0.5 * across + 0.4 * fwd))
        turns.update(arm_turns(body, side, (start_elbow, start_hand), (end_elbow, end_hand), times))
        return _per_frame(turns, len(times)), (f"{side}_elbow", f"{side}_hand")
    moving: tuple[str, ...] = ()
    if kind == "walk":
        amp, phase = rng.uniform(22, 34), rng.uniform(-0.3, 0.3)
        swing = _swing(times, amp, phase)
        bend = 35 * np.sin(math.pi * times) * rng.uniform(0.6, 1.2)  # the knee of the leg passing forward bends
        about("right_knee", LEFT, swing)
        about("left_knee", LEFT, -swing)
        about("right_foot" if "right_foot" in j else "right_knee", LEFT, bend)
        about("right_elbow", LEFT, -0.8 * swing)
        about("left_elbow", LEFT, 0.8 * swing)
        if body.family == "creature":
            about("tail2", UP, 0.5 * _swing(times, rng.uniform(10, 20), phase))
    elif kind == "trot":
        amp, phase = rng.uniform(18, 28), rng.uniform(-0.3, 0.3)
        swing = _swing(times, amp, phase)
        for leg, sign in (("right_knee_f", 1), ("left_knee_b", 1), ("left_knee_f", -1), ("right_knee_b", -1)):
            about(leg, LEFT, sign * swing)
        about("neck", LEFT, 0.3 * swing)
        about("tail2", UP, 1.5 * swing)
    elif kind == "tail":
        amp = rng.uniform(35, 55)
        sweep = _swing(times, amp, 0.0)
        about("tail2", UP, sweep)
        moving = ("tail2", "tail3")
        about("tail3", UP, 0.6 * sweep)
        about("head", UP, -0.4 * sweep)
        about("right_elbow", LEFT, _swing(times, rng.uniform(20, 40), 0.0))
    else:
        raise ValueError(f"motion {kind!r}: use one of reach, walk, trot, tail")
    return _per_frame(turns, len(times)), moving


def bvh_motion(rng_seed: list[int], family: str, motion: Motion, start: int, step: int) -> list[Body]:
    """A person at SHOT_FRAMES clip frames start, start + step, ...: the body rebuilt from the same draws."""
    return [make_body(np.random.default_rng(rng_seed), family, motion, start + i * step) for i in range(SHOT_FRAMES)]


# ----------------------------------------------------------------------------- camera and drawing

def place(bodies: list[Body], camera: Camera, size: tuple[int, int], rng: np.random.Generator):
    """One scale and shift for the whole motion (its union extent fills a random FILL share of the (H, W)
    frame); returns the projection ((n, 3) world -> (n, 3) x, y px and depth), or None when degenerate."""
    fit = fit_to_frame([s for b in bodies for s in b.solids], camera.rot, size, rng, FILL, (0.35, 0.65))
    if fit is None:
        return None
    k, shift = fit
    return lambda p: k * np.asarray(p, np.float64) @ camera.rot.T + shift  # noqa: E731


def _on_camera(body: Body, project) -> tuple[list[Solid], list[Mark]]:
    """The body's solids and marks in camera pixels under `project` (an orthographic scale, rotation, shift)."""
    origin = project(np.zeros((1, 3)))[0]
    lin = project(np.eye(3)) - origin  # rows: k * rot columns
    k = float(np.linalg.norm(lin[0]))
    rot = lin.T / k
    solids = [transformed(s, rot, k, origin) for s in body.solids]
    marks = [Mark(m.kind, project(m.points), m.width * k, m.solid) for m in body.marks]
    return solids, marks


def _crossings(drawn: Rendered, body: Body, pose_cam: np.ndarray, project) -> tuple[list[str], list[int], np.ndarray,
                                                                                    list[str], dict, dict]:
    """The frame's AnimatedDrawings skeleton (joints, parents, (J, 3) pose), its non-adjacent overlaps of
    >= MIN_EVIDENCE_PX as 'front-back' child joint names, and per bone of that skeleton (keyed by its index in
    child order, Skeleton.bones) its (H, W) bool shape and float32 entry depth."""
    joints, parents, pose, bone_of = reduce_skeleton(body, pose_cam, project, ad=True)
    cover, entry = _merge(drawn.cover, drawn.entry, bone_of)
    _, pairs = pair_truth(cover, entry, joints, parents, drawn.coverage >= 0.5)
    over = sorted(f"{p['front_part']}/{p['back_part']}" for p in pairs
                  if not p["adjacent"] and p["pixels"] >= MIN_EVIDENCE_PX)
    return joints, parents, pose, over, cover, entry


@dataclass
class Drawn:
    """A motion drawn frame by frame: frames (T, H, W, 3) uint8; coverage (T, H, W) float32; joints, parents of
    the AnimatedDrawings skeleton; poses (T, J, 3); over: per frame the crossings (_crossings); cover, entry: per
    frame, per bone (child order) its (H, W) bool shape and float32 entry depth."""

    frames: np.ndarray
    coverage: np.ndarray
    joints: list[str]
    parents: list[int]
    poses: np.ndarray
    over: list[list[str]]
    cover: list[dict]
    entry: list[dict]

    def key_parts(self) -> tuple:
        """((cover, entry) of the first frame, (cover, entry) of the last): the keys' bone shapes and depths."""
        return (self.cover[0], self.entry[0]), (self.cover[-1], self.entry[-1])

    def leaves_frame(self) -> bool:
        """True when the character touches the image border in some frame."""
        fg = self.coverage >= 0.5
        return bool(fg[:, 0].any() or fg[:, -1].any() or fg[:, :, 0].any() or fg[:, :, -1].any())

    def bone(self, child: str) -> int:
        """The index (child order) of the bone ending at joint `child`."""
        kids = [c for c, p in enumerate(self.parents) if p >= 0]
        return kids.index(self.joints.index(child))


def draw_motion(bodies: list[Body], project, size: tuple[int, int], look, seed: int,
                rewobbles: list[Rewobble | None] | None = None) -> Drawn:
    """Every body (one per frame) drawn in one look with one render seed (one paper, one hand), each with its
    shaky hand (rewobbles: per frame, None = the look's)."""
    frames, cover, poses, over, shapes, depths = [], [], [], [], [], []
    for i, body in enumerate(bodies):
        solids, marks = _on_camera(body, project)
        drawn = render(solids, marks, size, look, seed, None if rewobbles is None else rewobbles[i])
        joints, parents, pose, pairs, c, e = _crossings(drawn, body, project(body.pose), project)
        frames.append(drawn.rgb)
        cover.append(drawn.coverage)
        poses.append(pose)
        over.append(pairs)
        shapes.append(c)
        depths.append(e)
    poses_arr = np.stack(poses)
    poses_arr[..., 2] = np.round(poses_arr[..., 2], 3)
    return Drawn(np.stack(frames), np.stack(cover).astype(np.float32), joints, parents, poses_arr, over, shapes,
                 depths)


def redrawn_motion(rest: Body, turns: list[dict[int, np.ndarray]], times: np.ndarray, redraw: Redraw) -> list[Body]:
    """The rest body redrawn as at each time (T,) and posed by that time's turns."""
    return [posed(redrawn_body(rest, redraw.at(float(t))), tr) for t, tr in zip(times, turns)]


def redraw_iou(rest: Body, turns: list[dict[int, np.ndarray]], redraw: Redraw, project, size: tuple[int, int], look,
               seed: int, key1: np.ndarray) -> float:
    """Silhouette IoU of key1 (its (H, W) coverage) against key0's shapes and hand reposed rigidly to key1's
    pose: 1 for a rigid shot, lower the more the keys are redrawn."""
    body = posed(redrawn_body(rest, redraw.at(0.0)), turns[-1])
    solids, marks = _on_camera(body, project)
    again = render(solids, marks, size, look, seed, redraw.rewobble(0.0)).coverage >= 0.5
    now = key1 >= 0.5
    return float((again & now).sum() / max(int((again | now).sum()), 1))


def _involving(pairs: list[str], joints: tuple[str, ...]) -> set[str]:
    """The 'front/back' pairs with a bone ending at one of `joints`."""
    return {p for p in pairs if any(part.split("-")[-1] in joints for part in p.split("/"))}


def make_shot3d(index: int, size: tuple[int, int] = (256, 256), bvh_dir: Path | str | None = None,
                family: str | None = None, style: str | None = None, motion: str | None = None,
                redraw: float = 0.0) -> Shot3D:
    """Shot `index` (arrays only, nothing written): PLAN's family, style and motion unless given. With bvh_dir,
    people move along one of its clips (motion 'bvh:<clip>'). redraw: the amount by which the keys are redrawn
    (redraw.py; procedural motions only; 0: rigid). Deterministic per (index, size, clips, redraw)."""
    f0, s0, m0 = plan(index)
    family, style, motion = family or f0, style or s0, motion or m0
    seed = sample_seed("test", SHOT_INDEX_BASE + index)
    clips = _motions(str(bvh_dir) if bvh_dir else None)
    people = family in ("round", "thin", "props")
    if redraw and clips and people:
        raise ValueError("make_shot3d: redrawn keys need a procedural motion; leave bvh_dir out")
    times = np.linspace(0.0, 1.0, SHOT_FRAMES)
    for attempt in range(MAX_TRIES):
        draws = [seed, attempt, STREAM]
        rng = np.random.default_rng(draws)
        source, moving, rest = motion, (), None
        if clips and people:
            name, clip = clips[int(rng.integers(len(clips)))]
            step = int(rng.integers(2, 5))
            if len(clip.frames) <= (SHOT_FRAMES - 1) * step:
                continue
            start = int(rng.integers(len(clip.frames) - (SHOT_FRAMES - 1) * step))
            bodies = bvh_motion(draws + [1], family, clip, start, step)
            if bodies[0].motion != "bvh":
                continue
            source = f"bvh:{name}:{start}:{step}"
        else:
            rest = make_body(rng, family)
            turns, moving = procedural_turns(rest, motion, rng, times)
            bodies = [posed(rest, tr) for tr in turns]
        camera = make_camera(rng)
        project = place(bodies, camera, size, rng)  # the rigid motion's extent: the same for every amount
        if project is None:
            continue
        look = make_look3d(style, rng, scale=max(size) / 256.0)
        rewobbles = None
        if rest is not None:  # amount 0 changes no solid and keeps the look's hand: the rigid shot
            rd = draw_redraw(np.random.default_rng([seed, attempt, REDRAW_STREAM]), rest.solids, redraw, size,
                             look.wobble)
            bodies = redrawn_motion(rest, turns, times, rd)
            rewobbles = [rd.rewobble(float(t)) for t in times]
        drawn = draw_motion(bodies, project, size, look, seed * 7 + attempt, rewobbles)
        if drawn.leaves_frame():
            continue  # the character leaves the frame somewhere along the motion
        over = drawn.over
        if moving and _involving(over[0], moving) == _involving(over[-1], moving):
            continue  # the moving limb must come to cross (or leave) another part between the keys
        extra = {}
        if redraw:
            iou = redraw_iou(rest, turns, rd, project, size, look, seed * 7 + attempt, drawn.coverage[-1])
            if iou > 1 - REDRAW_IOU * redraw:
                continue  # the keys must differ beyond the skeleton by what was asked
            extra = {"redraw": redraw, "redraw_iou": round(iou, 4)}
        return Shot3D(drawn.frames, drawn.coverage, drawn.joints, drawn.parents, drawn.poses, (over[0], over[-1]),
                      family, style, source, camera.view, index, seed, attempt, extra=extra,
                      key_parts=drawn.key_parts())
    raise RuntimeError(f"shot {index} ({family}, {style}, {motion}): no usable motion in {MAX_TRIES} tries")


# ----------------------------------------------------------------------------- writing

def shot_name(shot: Shot3D) -> str:
    """The shot's directory name: its own, else index, family, style, motion kind."""
    return shot.name or f"h{shot.index:02d}_{shot.family}_{shot.style}_{shot.motion.split(':')[0]}"


def write_shot3d(shot: Shot3D, out_root: Path) -> Path:
    """Write one v1 shot directory under out_root (replaced if present): key0.png, key1.png (the first and last
    frames), gt/0000.png ... (every frame), shot.json (AnimatedDrawings skeleton, every frame's projected pose
    at t = i / (T - 1), frames = T, no T-junctions: the tool proposes them) and heldout.json (what it is)."""
    d = Path(out_root) / shot_name(shot)
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    n = len(shot.frames)
    for i, img in enumerate(shot.frames):
        _write_png(d / "gt" / f"{i:04d}.png", img)
    shutil.copyfile(d / "gt" / "0000.png", d / "key0.png")
    shutil.copyfile(d / "gt" / f"{n - 1:04d}.png", d / "key1.png")
    poses = [{"t": i / (n - 1), "joints": [[round(float(x), 2), round(float(y), 2), round(float(z), 3)]
                                           for x, y, z in shot.poses[i]]} for i in range(n)]
    data = {"format": FORMAT, "keyframes": ["key0.png", "key1.png"],
            "skeleton": {"joints": shot.joints, "parents": shot.parents}, "poses": poses, "frames": n,
            "t_junctions": [[], []], "ground_truth": "gt"}
    (d / "shot.json").write_text(_dump(data) + "\n")
    held = [k for k, v in (("body", shot.family == HELD_OUT_FAMILY), ("style", shot.style == HELD_OUT_STYLE)) if v]
    meta = {"generator": "3d", "split": "test", "index": shot.index, "seed": shot.seed, "attempt": shot.attempt,
            "family": shot.family, "style": shot.style, "motion": shot.motion, "view": shot.view,
            "held_out_of_occlusion_training": held, "size": list(shot.frames.shape[1:3]),
            "crossings": {"key0": shot.crossings[0], "key1": shot.crossings[1]}} | shot.extra
    (d / "heldout.json").write_text(json.dumps(meta, indent=1) + "\n")
    return d


def write_true_annotation(shot: Shot3D, d: Path) -> list[list[dict]]:
    """Annotate the written shot directory d as a person who knew the drawing would: per key, one painted
    occlusion mask per pair of bones that share no joint and overlap (occlusion3d.pair_truth: its pixels inside
    the drawn character, the bone entered first in front; the MAX_MASK_FILES largest where a side view makes
    more), key{k}_occlusion_{i}.png, and the T-junctions where
    the back bone's outline meets the front one's, written into shot.json's masks.occlusion and t_junctions.
    -> per key the regions' descriptions (front_part, back_part, pixels, t_junctions). The control for "are the
    masks the bottleneck": the same shot with what the occlusion stage could at best have predicted."""
    if not shot.key_parts:
        raise ValueError(f"{shot_name(shot)}: made without its keys' parts; regenerate it")
    data = json.loads((d / "shot.json").read_text())
    files, junctions, described = [], [], []
    for k, (cover, entry) in enumerate(shot.key_parts):
        fg = shot.coverage[0 if k == 0 else -1] >= 0.5
        masks, pairs = pair_truth(cover, entry, shot.joints, shot.parents, fg)
        kept = [(m, p) for m, p in zip(masks, pairs) if not p["adjacent"]]
        # a keyframe takes at most MAX_MASK_FILES painted regions: the largest, as a person would keep them
        kept = sorted(kept, key=lambda mp: -mp[1]["pixels"])[:MAX_MASK_FILES]
        names = [f"key{k}_occlusion_{i}.png" for i in range(len(kept))]
        for name, (m, _) in zip(names, kept):
            _write_png(d / name, (m * 255).astype(np.uint8))
        files.append(names)
        junctions.append([pt for _, p in kept for pt in p["t_junctions"]])
        described.append([{key: p[key] for key in ("front_part", "back_part", "pixels", "t_junctions")}
                          for _, p in kept])
    data["masks"] = {"foreground": [None, None], "occlusion": files}
    data["t_junctions"] = junctions
    (d / "shot.json").write_text(_dump(data) + "\n")
    return described
