"""Synthesize the sample shots: layered 2D characters drawn like ink on paper.

Usage: python data_samples/generate.py [--out data_samples] [--only NAME ...]

Each character is a skeleton whose bones carry a body part (capsule or
ellipse) with a white paper fill, an anti-aliased ink outline of varying
weight and an interior texture fixed in the bone's local frame. Parts are
painted back to front by depth (z, larger = farther). Every shot directory
follows /work/shared/SHOT_FORMAT.md ("inbetween-shot/1") and carries the
ground truth used by evaluation: gt/0000.png ... (one per output time) and
gt_occ/key{k}_occ{i}.png (overlap of a front part over a back part, for every
overlapping pair of non-adjacent bones; pairs listed in gt_occ/index.json).

Deterministic: every random choice comes from numpy generators seeded per
shot and per bone, and the drawing is plain OpenCV rasterization.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ops.shotio.interpolate import interpolate_pose as _loader_interpolate

FORMAT = "inbetween-shot/1"
FRAMES = 9  # output frames per shot, both keyframes included
SS = 4  # supersampling factor of the rasterizer
SHIFT = 4  # OpenCV fixed-point bits: sub-pixel accurate drawing
MIN_OVERLAP_PX = 12  # smaller overlaps are rounding noise, not occlusions
INK_WIDTH = 2.4  # mean outline width, output pixels
ARC_SAMPLES = 48  # outline vertices per half shape


# ----------------------------------------------------------------------------- character model

@dataclass(frozen=True)
class Part:
    """How one bone is drawn: shape, half-width (px), padding past the joints (px, ellipse), texture."""

    shape: str  # "capsule" | "ellipse"
    radius: float
    pad: float = 0.0
    texture: str = "stripes"  # "stripes" | "dots" | "zigzag" | "hatch" | "rings" | "face" | "buttons" | "none"


@dataclass
class Character:
    """Skeleton (names, parents) plus one Part per bone, keyed by the bone's child joint."""

    joints: list[str]
    parents: list[int]
    parts: dict[int, Part]
    seed: int
    strokes: dict[int, list] = field(default_factory=dict)  # child joint -> texture strokes (local frame)
    weight_phase: dict[int, np.ndarray] = field(default_factory=dict)  # child joint -> (3,) outline phases

    def __post_init__(self) -> None:
        """Draw every bone's texture and line-weight phases once, so they stay fixed over time."""
        for c, part in self.parts.items():
            rng = np.random.default_rng([self.seed, c])
            self.strokes[c] = make_texture(part.texture, rng)
            self.weight_phase[c] = rng.uniform(0, 2 * math.pi, 3)

    @property
    def bones(self) -> list[tuple[int, int]]:
        """(parent, child) pairs in child order, same order as ops.types.Skeleton.bones."""
        return [(p, c) for c, p in enumerate(self.parents) if p >= 0]

    def adjacent(self, b1: tuple[int, int], b2: tuple[int, int]) -> bool:
        """True when two bones share a joint."""
        return bool(set(b1) & set(b2))


def make_texture(kind: str, rng: np.random.Generator) -> list:
    """Texture strokes in the bone frame (u along 0..1 parent->child, v across in radius units).

    Each stroke is ("line", (n, 2) uv points, width px) or ("dot", (u, v), radius px).
    """
    strokes: list = []
    if kind == "stripes":
        for u in np.sort(rng.uniform(0.25, 0.78, rng.integers(2, 4))):
            bend = rng.uniform(-0.06, 0.06)
            v = np.linspace(-0.62, 0.62, 7)
            strokes.append(("line", np.stack([u + bend * (1 - v ** 2), v], 1), rng.uniform(1.1, 1.6)))
    elif kind == "dots":
        for _ in range(rng.integers(3, 6)):
            strokes.append(("dot", (rng.uniform(0.2, 0.8), rng.uniform(-0.45, 0.45)), rng.uniform(1.1, 1.8)))
    elif kind == "zigzag":
        n = int(rng.integers(4, 7))
        u = np.linspace(0.2, 0.8, n)
        v = np.where(np.arange(n) % 2 == 0, -0.42, 0.42) + rng.uniform(-0.08, 0.08, n)
        strokes.append(("line", np.stack([u, v], 1), rng.uniform(1.1, 1.5)))
    elif kind == "hatch":
        for u in np.linspace(0.25, 0.7, int(rng.integers(3, 5))):
            strokes.append(("line", np.array([[u, -0.5], [u + 0.12, 0.5]]), rng.uniform(1.0, 1.4)))
    elif kind == "rings":
        for u in np.linspace(0.3, 0.7, 2):
            v = np.linspace(-0.72, 0.72, 9)
            strokes.append(("line", np.stack([u + 0.05 * (1 - v ** 2), v], 1), 1.3))
        strokes.append(("dot", (0.5, 0.0), 1.6))
    elif kind == "face":  # bone runs neck -> top of head, so u ~ 0.55 is eye level
        strokes += [("dot", (0.6, -0.35), 1.7), ("dot", (0.6, 0.35), 1.7)]
        v = np.linspace(-0.35, 0.35, 7)
        strokes.append(("line", np.stack([0.33 + 0.08 * (v / 0.35) ** 2, v], 1), 1.3))
    elif kind == "buttons":
        strokes += [("dot", (u, 0.0), 1.5) for u in (0.35, 0.55, 0.75)]
        v = np.linspace(-0.7, 0.7, 9)
        strokes.append(("line", np.stack([0.18 - 0.04 * (1 - (v / 0.7) ** 2), v], 1), 1.6))  # belt
    return strokes


# ----------------------------------------------------------------------------- poses

def forward(parents: list[int], root: tuple[float, float], world_deg: dict[int, float],
            length: dict[int, float], z: dict[int, float]) -> np.ndarray:
    """(J, 3) joints from world bone angles (deg, y down: 90 = straight down) and lengths (px)."""
    out = np.zeros((len(parents), 3))
    out[0, :2] = root
    for c in range(1, len(parents)):  # parents precede children in every character here
        a = math.radians(world_deg[c])
        out[c, :2] = out[parents[c], :2] + length[c] * np.array([math.cos(a), math.sin(a)])
    out[:, 2] = [z.get(j, 0.0) for j in range(len(parents))]
    return out


def interpolate_pose(a: np.ndarray, b: np.ndarray, s: float, parents: list[int]) -> np.ndarray:
    """(J, 3) pose at fraction s, by the shot loader's own rule, so ground truth matches what it computes."""
    return _loader_interpolate(a, b, s, np.asarray(parents, dtype=np.int64))


def quantize(pose: np.ndarray) -> np.ndarray:
    """Round x, y to 0.01 px and z to 0.001 so the JSON values are exactly what gets drawn."""
    return np.concatenate([np.round(pose[:, :2], 2), np.round(pose[:, 2:], 3)], 1)


# ----------------------------------------------------------------------------- geometry of parts

def part_outline(part: Part, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closed centre line of a part's outline: (n, 2) points px, (n, 2) outward unit normals, (n,) param in [0, 2pi)."""
    d = p1 - p0
    phi = math.atan2(d[1], d[0])
    n = ARC_SAMPLES
    if part.shape == "capsule":
        a1 = phi + np.linspace(-math.pi / 2, math.pi / 2, n)
        a0 = phi + np.linspace(math.pi / 2, 3 * math.pi / 2, n)
        normals = np.concatenate([np.stack([np.cos(a1), np.sin(a1)], 1), np.stack([np.cos(a0), np.sin(a0)], 1)])
        centres = np.concatenate([np.repeat(p1[None], n, 0), np.repeat(p0[None], n, 0)])
        pts = centres + part.radius * normals
    else:
        s = np.linspace(0, 2 * math.pi, 2 * n, endpoint=False)
        a, b = 0.5 * float(np.hypot(*d)) + part.pad, part.radius
        rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
        pts = 0.5 * (p0 + p1) + np.stack([a * np.cos(s), b * np.sin(s)], 1) @ rot.T
        nrm = np.stack([b * np.cos(s), a * np.sin(s)], 1) @ rot.T
        normals = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    param = np.linspace(0, 2 * math.pi, len(pts), endpoint=False)
    return pts, normals, param


def signed_distance(part: Part, p0: np.ndarray, p1: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(k,) approximate signed distance (px, negative inside) of points q (k, 2) to a part's outline."""
    if part.shape == "capsule":
        d = p1 - p0
        t = np.clip(((q - p0) @ d) / max(float(d @ d), 1e-12), 0, 1)
        return np.linalg.norm(q - (p0 + t[:, None] * d), axis=1) - part.radius
    pts, _, _ = part_outline(part, p0, p1)
    dist = np.min(np.linalg.norm(q[:, None] - pts[None], axis=2), axis=1)
    inside = np.array([cv2.pointPolygonTest(pts.astype(np.float32), (float(x), float(y)), False) > 0 for x, y in q])
    return np.where(inside, -dist, dist)


def polygon_crossings(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(k, 2) intersection points of two closed polygons p (n, 2) and q (m, 2), px."""
    a, b = p, np.roll(p, -1, 0)
    c, d = q, np.roll(q, -1, 0)
    r = (b - a)[:, None]  # (n, 1, 2)
    s = (d - c)[None]  # (1, m, 2)
    den = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    ca = c[None] - a[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ca[..., 0] * s[..., 1] - ca[..., 1] * s[..., 0]) / den
        u = (ca[..., 0] * r[..., 1] - ca[..., 1] * r[..., 0]) / den
    hit = (np.abs(den) > 1e-12) & (t >= 0) & (t < 1) & (u >= 0) & (u < 1)
    i, _ = np.nonzero(hit)
    return a[i] + t[hit][:, None] * (b - a)[i]


# ----------------------------------------------------------------------------- rasterization

def _fixed(pts: np.ndarray) -> np.ndarray:
    """Output-pixel points -> int32 fixed-point coordinates of the supersampled canvas."""
    # pixel centres: output pixel (x, y) covers supersampled [x*SS, (x+1)*SS), centre at x*SS + (SS-1)/2
    return np.round((pts * SS + (SS - 1) / 2) * (1 << SHIFT)).astype(np.int32)


def _fill(shape: tuple[int, int], pts: np.ndarray) -> np.ndarray:
    """(h, w) float32 anti-aliased coverage of one polygon (n, 2) in output px."""
    img = np.zeros(shape, np.uint8)
    cv2.fillPoly(img, [_fixed(pts)], 255, cv2.LINE_AA, SHIFT)
    return img.astype(np.float32) / 255.0


def _texture(shape: tuple[int, int], strokes: list, p0: np.ndarray, p1: np.ndarray, radius: float) -> np.ndarray:
    """(h, w) float32 ink of the texture strokes mapped from the bone frame to the image."""
    img = np.zeros(shape, np.uint8)
    d = p1 - p0
    n = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
    for kind, geo, width in strokes:
        if kind == "line":
            uv = np.asarray(geo)
            pts = p0 + uv[:, :1] * d + uv[:, 1:] * radius * n
            cv2.polylines(img, [_fixed(pts)], False, 255, max(1, round(width * SS)), cv2.LINE_AA, SHIFT)
        else:
            c = p0 + geo[0] * d + geo[1] * radius * n
            cv2.circle(img, tuple(int(v) for v in _fixed(c[None])[0]), int(round(width * SS * (1 << SHIFT))),
                       255, -1, cv2.LINE_AA, SHIFT)
    return img.astype(np.float32) / 255.0


def draw_order(char: Character, pose: np.ndarray) -> list[int]:
    """Bone indices sorted back to front: mean joint depth descending, ties by bone index."""
    depth = [0.5 * (pose[p, 2] + pose[c, 2]) for p, c in char.bones]
    return sorted(range(len(depth)), key=lambda i: (-depth[i], i))


def render(char: Character, pose: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, list[np.ndarray]]:
    """Paint the character: (H, W, 3) uint8 RGB on white paper, and per bone (H, W) float32 coverage."""
    h, w = size
    big = (h * SS, w * SS)
    canvas = np.ones(big, np.float32)
    coverage: list[np.ndarray] = [np.zeros(size, np.float32)] * len(char.bones)
    for i in draw_order(char, pose):
        p, c = char.bones[i]
        part = char.parts[c]
        pts, nrm, param = part_outline(part, pose[p, :2], pose[c, :2])
        ph = char.weight_phase[c]
        width = INK_WIDTH * (1 + 0.16 * np.sin(2 * param + ph[0]) + 0.08 * np.sin(5 * param + ph[1]))
        outer = _fill(big, pts + nrm * (0.5 * width)[:, None])
        inner = _fill(big, pts - nrm * (0.5 * width)[:, None])
        tex = _texture(big, char.strokes[c], pose[p, :2], pose[c, :2], part.radius)
        ink = np.maximum(np.clip(outer - inner, 0, 1), tex * inner)
        canvas = canvas * (1 - outer) + (1 - ink) * outer
        coverage[i] = cv2.resize(outer, (w, h), interpolation=cv2.INTER_AREA)
    grey = cv2.resize(canvas, (w, h), interpolation=cv2.INTER_AREA)
    rgb = np.repeat(np.round(np.clip(grey, 0, 1) * 255).astype(np.uint8)[..., None], 3, 2)
    return rgb, coverage


# ----------------------------------------------------------------------------- occlusions and T-junctions

@dataclass
class Occlusion:
    """One overlap of a front part over a non-adjacent back part."""

    front: int  # bone index (Skeleton.bones order)
    back: int
    mask: np.ndarray  # (H, W) bool
    junctions: np.ndarray  # (k, 2) float64 px, visible crossings of the two outlines


def occlusions(char: Character, pose: np.ndarray, coverage: list[np.ndarray]) -> list[Occlusion]:
    """Every overlapping pair of non-adjacent parts, front over back, with its T-junctions."""
    order = draw_order(char, pose)
    rank = {b: r for r, b in enumerate(order)}
    bones = char.bones
    out = []
    for i in range(len(bones)):
        for j in range(i + 1, len(bones)):
            if char.adjacent(bones[i], bones[j]):
                continue
            mask = (coverage[i] > 0.5) & (coverage[j] > 0.5)
            if mask.sum() < MIN_OVERLAP_PX:
                continue
            front, back = (i, j) if rank[i] > rank[j] else (j, i)
            out.append(Occlusion(front, back, mask, t_junctions(char, pose, front, back, rank)))
    return out


def t_junctions(char: Character, pose: np.ndarray, front: int, back: int, rank: dict[int, int]) -> np.ndarray:
    """(k, 2) px points where the back part's outline meets the front part's outline, not hidden by a third part."""
    geo = {}
    for b in range(len(char.bones)):
        p, c = char.bones[b]
        geo[b] = (char.parts[c], pose[p, :2], pose[c, :2])
    pf, _, _ = part_outline(*geo[front])
    pb, _, _ = part_outline(*geo[back])
    pts = polygon_crossings(pb, pf)
    keep = np.ones(len(pts), bool)
    for other in range(len(char.bones)):
        if other in (front, back) or rank[other] < rank[back] or not len(pts):
            continue
        keep &= signed_distance(*geo[other], pts) > -1.0  # inside a later part: the junction is painted over
    pts = pts[keep]
    uniq: list[np.ndarray] = []
    for q in pts:  # merge duplicates from a crossing exactly at a polygon vertex
        if all(np.hypot(*(q - u)) > 2.0 for u in uniq):
            uniq.append(q)
    return np.array(uniq).reshape(-1, 2)


# ----------------------------------------------------------------------------- characters and shots

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
    cap = lambda r, t: Part("capsule", r, 0.0, t)  # noqa: E731
    parts = {1: Part("ellipse", 16.5, 3.0, "buttons"), 2: Part("ellipse", 13.0, 3.0, "face"),
             3: cap(5.5, "none"), 4: cap(6.5, "stripes"), 5: cap(5.5, "dots"),
             6: cap(5.5, "none"), 7: cap(6.5, "hatch"), 8: cap(5.5, "zigzag"),
             9: cap(6.0, "none"), 10: cap(7.5, "zigzag"), 11: cap(6.5, "stripes"),
             12: cap(6.0, "none"), 13: cap(7.5, "dots"), 14: cap(6.5, "hatch")}
    return Character(list(HUMAN_JOINTS), list(HUMAN_PARENTS), parts, seed)


def scaled(char: Character, k: float) -> Character:
    """The same character with every radius and pad multiplied by k (for larger frames)."""
    parts = {c: Part(p.shape, p.radius * k, p.pad * k, p.texture) for c, p in char.parts.items()}
    return Character(char.joints, char.parents, parts, char.seed)


def human_pose(root: tuple[float, float], angles: dict[int, float] | None = None, z: dict[int, float] | None = None,
               scale: float = 1.0) -> np.ndarray:
    """(15, 3) humanoid pose: rest angles overridden by `angles` (deg), depths by `z`, lengths times scale."""
    ang = {**HUMAN_REST, **(angles or {})}
    length = {c: v * scale for c, v in HUMAN_LENGTH.items()}
    return forward(HUMAN_PARENTS, root, ang, length, {**HUMAN_Z, **(z or {})})


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


TAIL_JOINTS = ["base", "s1", "s2", "s3", "s4", "s5", "tip"]
TAIL_PARENTS = [-1, 0, 1, 2, 3, 4, 5]
TAIL_LENGTH = {1: 43, 2: 39, 3: 35, 4: 32, 5: 29, 6: 26}


def tentacle(seed: int) -> Character:
    """A tapering 6-segment tentacle (non-humanoid) with ring and dot textures."""
    kinds = ["rings", "dots", "stripes", "zigzag", "rings", "dots"]
    radii = [12.5, 11.0, 9.5, 8.5, 7.5, 6.5]
    parts = {c: Part("capsule", radii[c - 1], 0.0, kinds[c - 1]) for c in range(1, 7)}
    return Character(list(TAIL_JOINTS), list(TAIL_PARENTS), parts, seed)


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


# ----------------------------------------------------------------------------- writing

def output_poses(spec: ShotSpec) -> tuple[np.ndarray, np.ndarray]:
    """(T,) times and (T, J, 3) poses at the FRAMES evenly spaced output times, keys quantized first."""
    k0, k1 = quantize(spec.keys[0]), quantize(spec.keys[1])
    times = np.arange(FRAMES) / (FRAMES - 1)
    poses = [k0] + [interpolate_pose(k0, k1, float(t), spec.char.parents) for t in times[1:-1]] + [k1]
    if not spec.two_poses_only:  # written to JSON: draw exactly the rounded values
        poses = [quantize(p) for p in poses]
    return times, np.stack(poses)


def _write_png(path: Path, img: np.ndarray) -> None:
    """Write an 8-bit grey (H, W) or RGB (H, W, 3) PNG (OpenCV wants BGR)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    data = img if img.ndim == 2 else img[..., ::-1]
    if not cv2.imwrite(str(path), np.ascontiguousarray(data), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise OSError(f"{path}: cannot write PNG")


def _mask_png(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool -> uint8 white = region."""
    return np.where(mask, 255, 0).astype(np.uint8)


def _pose_json(pose: np.ndarray) -> list:
    """(J, 3) -> JSON list of [x, y, z] with the quantized values."""
    return [[float(v) for v in row] for row in quantize(pose)]


def write_shot(spec: ShotSpec, out_root: Path) -> Path:
    """Render and write one shot directory under out_root; returns its path (replaced if present)."""
    d = out_root / spec.name
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    times, poses = output_poses(spec)
    frames = [render(spec.char, p, spec.size) for p in poses]
    for i, (rgb, _) in enumerate(frames):
        _write_png(d / "gt" / f"{i:04d}.png", rgb)
    _write_png(d / "key0.png", frames[0][0])
    _write_png(d / "key1.png", frames[-1][0])

    junctions, index = [], []
    for k, (pose, (_, cov)) in enumerate([(poses[0], frames[0]), (poses[-1], frames[-1])]):
        occ = occlusions(spec.char, pose, cov)
        pts = []
        for i, o in enumerate(occ):
            _write_png(d / "gt_occ" / f"key{k}_occ{i}.png", _mask_png(o.mask))
            index.append({"file": f"key{k}_occ{i}.png", "keyframe": k, "front_bone": o.front, "back_bone": o.back,
                          "front_joints": list(spec.char.bones[o.front]), "back_joints": list(spec.char.bones[o.back]),
                          "t_junctions": [[round(float(x), 1), round(float(y), 1)] for x, y in o.junctions]})
            pts += [[round(float(x), 1), round(float(y), 1)] for x, y in o.junctions]
        junctions.append(pts)
    (d / "gt_occ").mkdir(exist_ok=True)
    (d / "gt_occ" / "index.json").write_text(json.dumps(index, indent=1) + "\n")

    data: dict = {"format": FORMAT, "keyframes": ["key0.png", "key1.png"],
                  "skeleton": {"joints": spec.char.joints, "parents": spec.char.parents}}
    given = [0, len(times) - 1] if spec.two_poses_only else range(len(times))
    data["poses"] = [{"t": float(times[i]), "joints": _pose_json(poses[i])} for i in given]
    if spec.two_poses_only:
        data["frames"] = FRAMES
    data["t_junctions"] = junctions
    if spec.manual_masks:
        fg = np.max(np.stack(frames[0][1]), axis=0) > 0.5
        _write_png(d / "key0_fg.png", _mask_png(fg))
        occ_files = []
        for i, o in enumerate(occlusions(spec.char, poses[0], frames[0][1])):
            _write_png(d / f"key0_occ{i}.png", _mask_png(o.mask))
            occ_files.append(f"key0_occ{i}.png")
        data["masks"] = {"foreground": ["key0_fg.png", None], "occlusion": [occ_files, []]}
    data["ground_truth"] = "gt"
    (d / "shot.json").write_text(_dump(data) + "\n")
    return d


def _dump(data: dict) -> str:
    """JSON with every innermost list (names, parents, [x, y, z]) on one line: readable and diff-friendly."""
    text = json.dumps(data, indent=1)
    return re.sub(r"\[[^\[\]{}]*\]", lambda m: "[" + ", ".join(v.strip() for v in m.group(0)[1:-1].split(",")) + "]"
                  if m.group(0)[1:-1].strip() else "[]", text)


def generate(out_root: Path, names: list[str] | None = None) -> list[Path]:
    """Write the named shots (default: all) under out_root; returns their directories."""
    return [write_shot(SHOTS[n](), out_root) for n in (names or list(SHOTS))]


def main(argv: list[str] | None = None) -> None:
    """Command line: python data_samples/generate.py [--out DIR] [--only NAME ...]."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    ap.add_argument("--only", nargs="*", choices=list(SHOTS), default=None)
    args = ap.parse_args(argv)
    for d in generate(args.out, args.only):
        data = json.loads((d / "shot.json").read_text())
        print(f"{d}: t_junctions per key {[len(t) for t in data['t_junctions']]}")


if __name__ == "__main__":
    main()
