"""Real drawings, puppeted: two-key shots whose texture is a photographed child's drawing, with true in-betweens.

    python benchmarks/realdev_shots.py REALDEV_DIR OUT_DIR [--only char1:dab char4:wave_hello:redrawn ...]
    python benchmarks/realdev_shots.py REALDEV_DIR OUT_DIR --plan heldout   # the clips the set leaves out
    python -m assets.cli eval OUT_DIR --out EVAL_DIR          # then score ours, RIFE-direct and the rest

REALDEV_DIR holds AnimatedDrawings' example characters and clips (facebookresearch/AnimatedDrawings, MIT): either
REALDEV_DIR/animated_drawings/charN or REALDEV_DIR/charN (char_cfg.yaml, texture.png, mask.png; the person's
skeleton and mask) with bvh/ (the .bvh clips and their retarget configs) beside them. Each drawing is one pose;
the second key and the in-betweens are made by an independent puppet (benchmarks/puppet.py: per-bone parts,
blend skinning at joints, parts in depth order, paper where the drawing moved away) that shares nothing with
the method's deformation or rendering, as the 3D generator plays the world for heldout_shots.py. The motion is
a clip retargeted onto the character by the project's own retargeter, as `inbetween motion --bvh CLIP --retarget
CFG` does (the drawing is the clip's first frame); a window of 9 frames is chosen where the end poses lie far
apart and, preferably, a limb comes to cross another part. Characters the configs cannot drive (not humanoid)
are skipped and named. The "redrawn" variant warps key1 and the in-betweens by a smooth random displacement
growing from 0 at t = 0 to REDRAW_PX at t = 1 (a second drawing is never a rigid repose), joints with it.

One shot: 9 frames at 256 x 256 px, key0 / key1 the first and last, gt/ all nine, shot.json every frame's
skeleton (x, y px, z larger = farther, `poses` at t = i / 8, no T-junctions), realdev.json what it holds. Each
shot is loaded back with ops.shotio.load.load_shot and checked as heldout_shots.py checks its own, and
OUT_DIR/previews/<shot>.png shows the parts, then every frame with the skeleton over it (keys framed red).
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import json
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy import ndimage

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.bench_masks import load_character  # noqa: E402
from benchmarks.heldout_shots import check_shot  # noqa: E402
from benchmarks.puppet import (  # noqa: E402
    Rig,
    build_rig,
    moving_together,
    paper_field,
    part_labels,
    render,
    rigid_maps,
    skeleton_bones,
)  # noqa: E402
from ops.errors import ShotError  # noqa: E402
from ops.motion.animated_drawings import read_retarget  # noqa: E402
from ops.motion.bvh import BVH, frame_slice, parse_bvh  # noqa: E402
from ops.motion.fit import fit_clip  # noqa: E402
from ops.motion.retarget import check_names, lacking, retarget  # noqa: E402

FORMAT = "inbetween-shot/1"
SIZE = 256  # output frame, px (square)
WORK = 2  # the puppet renders at WORK x the output size, then area-averages down: anti-aliased edges
FRAMES = 9
FILL = 0.86  # share of the frame the window's motion fills
INK_REACH = 0.04  # ink this close to the person's mask (x the character's height) moves with it
INK_STEP = 0.12  # RGB distance from the paper's colour that makes a pixel ink
DISK = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
FEATHER = 16  # work px over which the photo fades into the paper that pads it
STRIDES = (1, 2, 3, 4, 5, 6)  # clip frames (at <= 30 fps) between two shot frames
BLEND = 0.025  # half-width of the skin blend at a joint, x the character's height
REDRAW_PX = 3.0  # the redrawn variant's largest displacement at t = 1, output px
SCOUT_SCALE = 0.25  # the drawing's scale when scouting windows

# (character, clip, variant): two clips per character, every clip at least once, and three redrawn twins of plain
# shots. char2 does not jump: her skirt is cut between the thighs' parts, and a crouch tears it apart
PLAN = (("char1", "dab", "plain"), ("char1", "jumping_jacks", "plain"), ("char2", "wave_hello", "plain"),
        ("char2", "dab", "plain"), ("char3", "dab", "plain"), ("char3", "jumping_jacks", "plain"),
        ("char4", "wave_hello", "plain"), ("char4", "jumping", "plain"),
        ("char1", "dab", "redrawn"), ("char3", "jumping_jacks", "redrawn"), ("char4", "wave_hello", "redrawn"))

# The clips the plan above leaves out, each character's other motions: a split never tuned on (the same drawings,
# other overlaps). char2's jumping is left out for her skirt, as above
HELDOUT_PLAN = (("char1", "wave_hello", "plain"), ("char1", "jumping", "plain"), ("char2", "jumping_jacks", "plain"),
                ("char3", "wave_hello", "plain"), ("char3", "jumping", "plain"), ("char4", "dab", "plain"),
                ("char4", "jumping_jacks", "plain"), ("char1", "wave_hello", "redrawn"))

# A character neither plan holds, never tuned on: the six-armed char5 (its numbered arms driven as the humanoid's,
# ops.motion.animated_drawings.numbered_copies), whose arms overlap one another as well as the body
SIX_ARMS_PLAN = (("char5", "dab", "plain"), ("char5", "wave_hello", "plain"), ("char5", "jumping_jacks", "plain"),
                 ("char5", "jumping", "plain"))

LIMBS = (("right_elbow", "right_arm"), ("right_hand", "right_arm"), ("left_elbow", "left_arm"),
         ("left_hand", "left_arm"), ("right_knee", "right_leg"), ("right_foot", "right_leg"),
         ("left_knee", "left_leg"), ("left_foot", "left_leg"), ("neck", "head"))


@dataclass(frozen=True)
class Character:
    """A photographed drawing with its person-made mask and skeleton, in texture pixels."""

    name: str
    texture: np.ndarray  # (H, W, 3) float32 RGB
    mask: np.ndarray  # (H, W) bool
    joints: tuple[str, ...]
    parents: np.ndarray  # (J,) int64
    rest: np.ndarray  # (J, 2) float64 px

    @property
    def height(self) -> float:
        """The drawn character's height, px (its mask's rows)."""
        rows = np.nonzero(self.mask.any(1))[0]
        return float(rows[-1] - rows[0] + 1)


@dataclass(frozen=True)
class Window:
    """Where in a retargeted clip a shot is taken: clip frames start + stride * i, i < FRAMES."""

    start: int
    stride: int
    span: float  # the farthest joint's travel between the end poses (root-relative), x the character's height
    crossing: tuple[float, ...]  # per frame: share of the character's pixels where a part covers one it does not touch
    score: float

    @property
    def frames(self) -> np.ndarray:
        return self.start + self.stride * np.arange(FRAMES)


def characters_dir(realdev: Path) -> Path:
    """The folder that holds char1 ... and bvh/ (REALDEV_DIR or REALDEV_DIR/animated_drawings)."""
    for d in (realdev / "animated_drawings", realdev):
        if (d / "bvh").is_dir() and any(d.glob("char*/char_cfg.yaml")):
            return d
    raise SystemExit(f"{realdev}: no charN/char_cfg.yaml and bvh/ there (nor under animated_drawings/)")


def read_character_folder(folder: Path) -> Character:
    """The drawing, the person's mask and skeleton of one AnimatedDrawings character folder."""
    drawing, mask, pose, skeleton = load_character(folder)
    return Character(folder.name, drawing, mask, tuple(skeleton.joints), np.asarray(skeleton.parents, np.int64),
                     pose[:, :2].astype(np.float64))


def clip_motion(ch: Character, bvh: BVH, bvh_file: Path, configs: list[Path]) -> tuple[np.ndarray, np.ndarray, str]:
    """((F, J, 3) poses in texture px, (F,) clip frame indices, config name): the clip (thinned to <= 30 fps)
    retargeted onto the character by the config written for its skeleton and fitted with the drawing as its
    first frame, as `inbetween motion --bvh CLIP --retarget CFG` does. ShotError when no config drives it."""
    for cfg_file in configs:
        config = read_retarget(cfg_file)
        try:
            check_names(bvh, bvh_file, config, ch.joints)
        except ShotError:
            continue
        idx = frame_slice(None, bvh.frames, bvh.frame_time)
        key = np.c_[ch.rest, np.zeros(len(ch.rest))]
        clip = retarget(bvh, bvh_file, config, idx, ch.joints, ch.parents, key)
        return fit_clip(clip, ch.parents, np.array([0]), key[None]), idx, cfg_file.name
    raise ShotError(bvh_file, "retarget", f"no retarget config beside it drives {ch.name}'s skeleton",
                    "give a humanoid (AnimatedDrawings' joint names) or a config for this clip")


def scaled_character(ch: Character, scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(texture, mask, (sx, sy)) resized by scale (area-averaged), the per-axis factors the rounding left."""
    h, w = ch.mask.shape
    nw, nh = max(1, round(w * scale)), max(1, round(h * scale))
    tex = cv2.resize(ch.texture, (nw, nh), interpolation=cv2.INTER_AREA)
    mask = cv2.resize(ch.mask.astype(np.float32), (nw, nh), interpolation=cv2.INTER_AREA) > 0.5
    return tex, mask, np.array([nw / w, nh / h])


def to_pixels(points: np.ndarray, factor: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """x, y of (..., 2+) texture-pixel points in a grid scaled by factor (2,) and shifted by offset (2,): pixel
    centres map onto pixel centres."""
    out = np.array(points, np.float64, copy=True)
    out[..., :2] = (out[..., :2] + 0.5) * factor - 0.5 + offset
    return out


def scout_rig(ch: Character, poses: np.ndarray) -> tuple[Rig, np.ndarray, np.ndarray]:
    """A small rig of the drawing (SCOUT_SCALE, padded by half its height) to measure windows, its (sx, sy) and
    its offset (2,) px."""
    tex, mask, factor = scaled_character(ch, SCOUT_SCALE)
    m = int(round(0.5 * ch.height * SCOUT_SCALE))
    tex, mask = np.pad(tex, ((m, m), (m, m), (0, 0))), np.pad(mask, m)
    offset = np.array([m, m], np.float64)
    rest = to_pixels(ch.rest, factor, offset)
    blend = max(1.5, BLEND * ch.height * SCOUT_SCALE)
    rig = build_rig(tex, tex, mask, rest, ch.parents, blend, moving_together(ch.rest, ch.parents, poses))
    return rig, factor, offset


def choose_window(ch: Character, poses: np.ndarray) -> Window:
    """The window of FRAMES clip frames (any start, a stride of STRIDES) whose end poses lie farthest apart,
    doubled where a limb crosses another part in some frame and that covering changes between the keys; it must
    move on (its path at most 1.6 x its span), keep every step under 0.3 heights, its extent under 1.5 and the
    root's travel under 0.5 (so the character stays large in the frame)."""
    h = ch.height
    rel = (poses[:, :, :2] - poses[:, :1, :2]) / h
    rig, factor, offset = scout_rig(ch, poses)
    area = float(rig.mask.sum())
    cross_cache: dict[int, float] = {}

    def crossing(f: int) -> float:
        if f not in cross_cache:  # the root held where it was drawn: covering does not depend on where it went
            pose = poses[f].copy()
            pose[:, :2] += ch.rest[0] - pose[0, :2]
            cross_cache[f] = float(render(rig, to_pixels(pose, factor, offset)).crossing.sum()) / area
        return cross_cache[f]

    best = None
    n = len(poses)
    for stride in STRIDES:
        for start in range(0, n - stride * (FRAMES - 1)):
            f = start + stride * np.arange(FRAMES)
            travel = np.linalg.norm(rel[f[-1]] - rel[f[0]], axis=1)
            j = int(np.argmax(travel))
            span = float(travel[j])
            path = float(np.linalg.norm(np.diff(rel[f, j], axis=0), axis=1).sum())
            step = float(np.linalg.norm(np.diff(poses[f, :, :2], axis=0), axis=2).max()) / h
            xy = poses[f, :, :2].reshape(-1, 2)
            extent = float(np.ptp(xy, axis=0).max()) / h
            drift = float(np.linalg.norm(poses[f[-1], 0, :2] - poses[f[0], 0, :2])) / h
            if span < 0.15 or path > 1.6 * span or step > 0.3 or extent > 1.5 or drift > 0.5:
                continue
            if best is not None and span * 3.0 <= best.score:
                continue  # even a crossing could not lift it above the best
            cross = tuple(crossing(int(i)) for i in f)
            crosses = max(cross) > 0.01 and abs(cross[-1] - cross[0]) > 0.005
            score = span * (3.0 if crosses else 1.0)
            if best is None or score > best.score:
                best = Window(int(start), int(stride), span, cross, score)
    if best is None:
        raise ValueError(f"{ch.name}: no window of the clip moves enough")
    return best


@dataclass(frozen=True)
class Filmed:
    """One shot's frames and skeleton, at the output size."""

    frames: np.ndarray  # (FRAMES, SIZE, SIZE, 3) uint8 RGB
    poses: np.ndarray  # (FRAMES, J, 3) float64 x, y output px, z larger = farther
    parts: np.ndarray  # (FRAMES, SIZE, SIZE) int16 part seen per pixel (-1: paper), for the preview
    pairs: dict[tuple[str, str], int]  # (front limb, covered limb) -> work pixels over all frames
    scale: float  # output px per texture px


def limb(name: str) -> str:
    """The limb a part (named by its distal joint) belongs to: right_arm, left_leg, head ..., else body (a numbered
    copy, char5's right_elbow2, belongs to the limb it copies)."""
    return next((group for joint, group in LIMBS if joint == name.rstrip("0123456789")), "body")


def motion_box(ch: Character, poses: np.ndarray, window: Window) -> np.ndarray:
    """(x0, y0, x1, y1) texture px around the drawing in every pose of the window (each mask pixel carried by
    its part's rigid map)."""
    bones = skeleton_bones(ch.rest, ch.parents)
    parts = part_labels(ch.mask, ch.rest, ch.parents, bones, np.arange(len(bones)))[ch.mask].astype(np.int64)
    ys, xs = np.nonzero(ch.mask)
    pts = np.stack([xs, ys], 1).astype(np.float64)
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    for f in window.frames:
        maps = rigid_maps(ch.rest, ch.parents, bones, poses[f])[parts]
        moved = np.einsum("nij,nj->ni", maps[:, :, :2], pts) + maps[:, :, 2]
        lo, hi = np.minimum(lo, moved.min(0) - 1), np.maximum(hi, moved.max(0) + 1)
    return np.concatenate([lo, hi])


def redraw_field(n: int, seed: int, amplitude: float) -> np.ndarray:
    """(n, n, 2) float32 smooth random displacement, px: a few low-frequency waves (wavelengths 0.4 to 1.2
    frames), scaled so that its largest length is amplitude."""
    rng = np.random.default_rng([2027, seed])
    y, x = np.mgrid[0:n, 0:n].astype(np.float64) / n
    field = np.zeros((n, n, 2))
    for _ in range(4):
        direction = rng.normal(size=2)
        k = direction / np.linalg.norm(direction) / rng.uniform(0.4, 1.2)
        wave = np.sin(2 * np.pi * (k[0] * x + k[1] * y) + rng.uniform(0, 2 * np.pi))
        field += wave[..., None] * rng.normal(size=2)
    return (field * amplitude / np.linalg.norm(field, axis=2).max()).astype(np.float32)


def displaced(points: np.ndarray, field: np.ndarray, t: float) -> np.ndarray:
    """(J, 2) points moved as the image warp out(q) = in(q - t D(q)) moves them: q = p + t D(q), solved by
    fixed-point steps (D is smooth and a few px)."""
    n = field.shape[0]
    q = points.copy()
    for _ in range(8):
        ix = np.clip(np.round(q).astype(int), 0, n - 1)
        q = points + t * field[ix[:, 1], ix[:, 0]]
    return q


def moving_pixels(tex: np.ndarray, mask: np.ndarray, reach_px: float) -> np.ndarray:
    """(H, W) bool what moves with the character: the person's mask, the ink around it that the mask missed
    (within reach_px, off the paper's colour by INK_STEP, touching the mask: a crayon stroke past a tight
    mask would otherwise stay behind as a ghost), and the ink's soft outer edge (2 px)."""
    r = max(1, int(round(reach_px)))
    near = cv2.dilate(mask.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))) > 0
    paper = paper_field(tex, ~(cv2.dilate(mask.astype(np.uint8), DISK, iterations=3) > 0), 0.2 * max(mask.shape))
    ink = near & (np.linalg.norm(tex - paper, axis=2) > INK_STEP)
    pieces, _ = ndimage.label(mask | ink)
    grown = np.isin(pieces, np.unique(pieces[mask]))
    return cv2.dilate(grown.astype(np.uint8), DISK) > 0


def film(ch: Character, poses: np.ndarray, window: Window, redrawn_seed: int | None) -> Filmed:
    """Render the window's frames: the drawing scaled so the motion fills FILL of the frame, padded with paper,
    posed by the puppet at WORK x the output size and area-averaged down; redrawn_seed: warp as a redrawing."""
    n = WORK * SIZE
    box = motion_box(ch, poses, window)
    scale = n * FILL / float(max(box[2] - box[0], box[3] - box[1]))
    tex, mask, factor = scaled_character(ch, scale)
    corners = to_pixels(box.reshape(2, 2), factor, np.zeros(2))
    off = np.round(n / 2 - corners.mean(0)).astype(int)  # the photo's top-left corner in frame work px
    h, w = mask.shape
    origin = np.minimum(off, 0)  # canvas: the frame and the whole photo (the drawing may start outside the frame)
    far = np.maximum(off + [w, h], n)
    ch_w, ch_h = far - origin
    ox, oy = off - origin
    body = moving_pixels(tex, mask, INK_REACH * ch.height * scale)
    halo = cv2.dilate(body.astype(np.uint8), DISK, iterations=3) > 0
    # the paper: its smooth colour from the photo around the character, carried on past the photo's edges, and
    # the photo faded into it over FEATHER px there (a photo's border is darker or lighter than its middle)
    pad = ((oy, ch_h - oy - h), (ox, ch_w - ox - w))
    paper = cv2.copyMakeBorder(paper_field(tex, ~halo, 0.08 * n), *pad[0], *pad[1], cv2.BORDER_REPLICATE)
    inner = ndimage.distance_transform_edt(np.pad(np.ones((h, w), bool), 1))[1:-1, 1:-1]
    fade = np.maximum(np.clip((inner - 1) / FEATHER, 0, 1), body)[..., None]
    canvas = np.pad(tex * fade, pad + ((0, 0),)) + paper * np.pad(1 - fade, pad + ((0, 0),), constant_values=1)
    canvas = canvas.astype(np.float32)
    body = np.pad(body, pad)
    background = canvas.copy()
    background[body] = paper[body]
    shift = np.array([ox, oy], np.float64)
    rest = to_pixels(ch.rest, factor, shift)
    rig = build_rig(canvas, background, body, rest, ch.parents, max(2.0, BLEND * ch.height * scale),
                    moving_together(ch.rest, ch.parents, poses))
    field = None if redrawn_seed is None else redraw_field(n, redrawn_seed, REDRAW_PX * WORK)
    grid = np.mgrid[0:n, 0:n].astype(np.float32)
    names = [ch.joints[j] for j in rig.bones]
    frames, out_poses, parts, pairs = [], [], [], {}
    for i, f in enumerate(window.frames):
        pose = to_pixels(poses[f], factor, shift)
        pose[:, 2] = poses[f, :, 2] * factor.mean() / WORK
        shot = render(rig, pose)
        crop = (slice(-origin[1], -origin[1] + n), slice(-origin[0], -origin[0] + n))
        image, front = shot.image[crop], shot.front[crop]
        covered = shot.covered[crop]
        for a, b in zip(front[covered >= 0], covered[covered >= 0]):
            key = (limb(names[a]), limb(names[b]))
            pairs[key] = pairs.get(key, 0) + 1
        xy = pose[:, :2] + origin  # canvas -> frame work px
        t = i / (FRAMES - 1)
        if field is not None and i > 0:
            image = cv2.remap(image, grid[1] - t * field[..., 0], grid[0] - t * field[..., 1], cv2.INTER_LINEAR,
                              borderMode=cv2.BORDER_REPLICATE)
            front = cv2.remap(front, grid[1] - t * field[..., 0], grid[0] - t * field[..., 1], cv2.INTER_NEAREST,
                              borderMode=cv2.BORDER_REPLICATE)
            xy = displaced(xy, field, t)
        small = cv2.resize(image, (SIZE, SIZE), interpolation=cv2.INTER_AREA)
        frames.append(np.round(np.clip(small, 0, 1) * 255).astype(np.uint8))
        parts.append(front[WORK // 2::WORK, WORK // 2::WORK])
        out_poses.append(np.c_[(xy + 0.5) / WORK - 0.5, pose[:, 2]])
    return Filmed(np.stack(frames), np.stack(out_poses), np.stack(parts), pairs, float(scale * factor.mean() / WORK))


def _write_png(path: Path, rgb: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), np.ascontiguousarray(rgb[..., ::-1]), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise OSError(f"{path}: cannot write PNG")


def write_shot(d: Path, ch: Character, filmed: Filmed, meta: dict) -> Path:
    """One v1 shot directory (replaced if present): key0.png, key1.png, gt/, shot.json, realdev.json."""
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    for i, img in enumerate(filmed.frames):
        _write_png(d / "gt" / f"{i:04d}.png", img)
    shutil.copyfile(d / "gt" / "0000.png", d / "key0.png")
    shutil.copyfile(d / "gt" / f"{FRAMES - 1:04d}.png", d / "key1.png")
    poses = [{"t": i / (FRAMES - 1), "joints": [[round(float(x), 2), round(float(y), 2), round(float(z), 3)]
                                                for x, y, z in filmed.poses[i]]} for i in range(FRAMES)]
    data = {"format": FORMAT, "keyframes": ["key0.png", "key1.png"],
            "skeleton": {"joints": list(ch.joints), "parents": ch.parents.tolist()}, "poses": poses,
            "frames": FRAMES, "t_junctions": [[], []], "ground_truth": "gt"}
    (d / "shot.json").write_text(json.dumps(data, indent=1) + "\n")
    (d / "realdev.json").write_text(json.dumps(meta, indent=1) + "\n")
    return d


PART_COLOURS = np.array([[230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200], [245, 130, 48],
                         [145, 30, 180], [70, 240, 240], [240, 50, 230], [210, 245, 60], [250, 190, 212],
                         [0, 128, 128], [220, 190, 255], [170, 110, 40], [128, 0, 0], [170, 255, 195],
                         [128, 128, 0]], np.uint8)


def contact_sheet(d: Path, filmed: Filmed, out: Path) -> Path:
    """out/<shot>.png: the parts of key0 coloured, then every frame above the same frame with the skeleton
    drawn over it (joints nearer = brighter green), keys framed red; the shot's name and content above."""
    data = json.loads((d / "shot.json").read_text())
    meta = json.loads((d / "realdev.json").read_text())
    parents = data["skeleton"]["parents"]
    tint = PART_COLOURS[np.maximum(filmed.parts[0], 0) % len(PART_COLOURS)][..., ::-1]
    key0 = filmed.frames[0][..., ::-1]
    parts = np.where((filmed.parts[0] >= 0)[..., None], (0.45 * key0 + 0.55 * tint).astype(np.uint8), key0)
    tiles = [np.concatenate([parts, np.full_like(parts, 255)], axis=0)]
    for i in range(FRAMES):
        img = np.ascontiguousarray(filmed.frames[i][..., ::-1])
        over = img.copy()
        pose = np.array(data["poses"][i]["joints"])
        for c, p in enumerate(parents):
            if p >= 0:
                cv2.line(over, tuple(int(round(v)) for v in pose[p, :2]), tuple(int(round(v)) for v in pose[c, :2]),
                         (200, 90, 0), 1, cv2.LINE_AA)
        z = pose[:, 2]
        near = (z.max() - z) / max(float(np.ptp(z)), 1e-6)
        for (x, y, _), a in zip(pose, near):
            cv2.circle(over, (int(round(x)), int(round(y))), 2, (0, int(80 + 170 * a), 0), -1, cv2.LINE_AA)
        pair = np.concatenate([img, over], axis=0)
        if i in (0, FRAMES - 1):
            cv2.rectangle(pair, (0, 0), (pair.shape[1] - 1, pair.shape[0] - 1), (0, 0, 220), 2)
        cv2.putText(pair, f"{i}", (4, 14), cv2.FONT_HERSHEY_PLAIN, 1.0, (40, 40, 200), 1, cv2.LINE_AA)
        tiles.append(pair)
    sheet = np.concatenate(tiles, axis=1)
    head = np.full((22, sheet.shape[1], 3), 255, np.uint8)
    text = (f"{d.name}: {meta['character']} {meta['clip']} BVH frames {meta['bvh_frames'][0]}..."
            f"{meta['bvh_frames'][-1]} step {meta['bvh_step']}, {meta['variant']}, crossing {meta['crossing']}")
    cv2.putText(head, text, (4, 15), cv2.FONT_HERSHEY_PLAIN, 1.0, (0, 0, 0), 1, cv2.LINE_AA)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{d.name}.png"
    cv2.imwrite(str(path), np.concatenate([head, sheet], axis=0), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return path


def what_it_holds(filmed: Filmed, ch: Character, poses: np.ndarray, window: Window) -> str:
    """A name for the shot's content: the limb that crosses most over the part it covers most
    ('left_arm_over_body'), or the limb that travels farthest ('right_leg_moves')."""
    pairs = {k: v for k, v in filmed.pairs.items() if k[0] != k[1]}
    if pairs and max(window.crossing) > 0.01:
        front, back = max(sorted(pairs), key=lambda k: pairs[k])
        return f"{front}_over_{back}"
    rel = poses[window.frames, :, :2] - poses[window.frames, :1, :2]
    j = int(np.argmax(np.linalg.norm(rel[-1] - rel[0], axis=1)))
    return f"{limb(ch.joints[j])}_moves"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("realdev", type=Path, help="folder of AnimatedDrawings' characters and bvh/ (see above)")
    ap.add_argument("out", type=Path, help="folder to write the shots into (one sub-folder each)")
    ap.add_argument("--only", nargs="*", default=None, help="plan entries to make, as charN:clip[:redrawn]")
    ap.add_argument("--plan", choices=("dev", "heldout", "six-arms"), default="dev",
                    help="dev: the development set (rdNN_...); heldout: the clips it leaves out (rhNN_...), never tuned "
                         "on; six-arms: char5, whom neither holds (rxNN_...), never tuned on")
    args = ap.parse_args(argv)
    base = characters_dir(args.realdev)
    configs = sorted((base / "bvh").glob("*.yaml"))
    clips = {p.stem: p for p in sorted((base / "bvh").glob("*.bvh"))}
    chars = {d.name: read_character_folder(d) for d in sorted(base.glob("char*")) if (d / "char_cfg.yaml").is_file()}
    skipped = {}
    for name, ch in chars.items():  # which characters the configs can drive at all
        lacks = [sorted({j for _, j in lacking(read_retarget(c), ch.joints)}) for c in configs]
        if all(lacks):
            skipped[name] = (f"no retarget config drives its skeleton (it lacks {', '.join(min(lacks, key=len)[:3])} "
                             "...): not a humanoid")
            print(f"{name}: skipped: {skipped[name]}")
    records, cache = [], {}
    plan, prefix = {"dev": (PLAN, "rd"), "heldout": (HELDOUT_PLAN, "rh"), "six-arms": (SIX_ARMS_PLAN, "rx")}[args.plan]
    for index, (cname, clip, variant) in enumerate(plan):
        tag = f"{cname}:{clip}" + (":redrawn" if variant == "redrawn" else "")
        if args.only and tag not in args.only:
            continue
        if cname in skipped or cname not in chars or clip not in clips:
            print(f"{tag}: not available here, skipped")
            continue
        start = time.process_time()
        ch = chars[cname]
        if (cname, clip) not in cache:
            poses, idx, cfg = clip_motion(ch, parse_bvh(clips[clip]), clips[clip], configs)
            cache[cname, clip] = poses, idx, cfg, choose_window(ch, poses)
        poses, idx, cfg, window = cache[cname, clip]
        filmed = film(ch, poses, window, index if variant == "redrawn" else None)
        what = what_it_holds(filmed, ch, poses, window)
        name = f"{prefix}{index:02d}_{cname}_{clip}_{what}" + ("_redrawn" if variant == "redrawn" else "")
        meta = {"source": "AnimatedDrawings examples (MIT)", "character": cname, "clip": clip, "retarget": cfg,
                "bvh_frames": [int(idx[f]) for f in window.frames], "bvh_step": int(idx[window.stride] - idx[0]),
                "variant": variant, "redraw_px": REDRAW_PX if variant == "redrawn" else 0.0,
                "holds": what, "span": round(window.span, 3),
                "crossing": [round(c, 3) for c in window.crossing], "scale": round(filmed.scale, 4)}
        d = write_shot(args.out / name, ch, filmed, meta)
        check_shot(d)
        sheet = contact_sheet(d, filmed, args.out / "previews")
        records.append(meta | {"shot": name})
        print(f"{name:52s} BVH frames {meta['bvh_frames'][0]:3d}..{meta['bvh_frames'][-1]:3d} step {meta['bvh_step']} "
              f"span {window.span:.2f} crossing max {max(window.crossing):.3f} ({time.process_time() - start:.1f} "
              f"CPU s) -> {sheet.relative_to(args.out)}", flush=True)
    (args.out / "previews").mkdir(parents=True, exist_ok=True)
    (args.out / "previews" / "manifest.json").write_text(json.dumps({"shots": records, "skipped": skipped},
                                                                    indent=1) + "\n")
    print(f"{len(records)} shots written and loaded back; score them with: python -m assets.cli eval {args.out} "
          "--out EVAL_DIR")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
