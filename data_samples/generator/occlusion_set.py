"""The generated occlusion dataset (issue 15): one sample = one keyframe with its occlusion ground truth.

A sample is a random character of one class (arm_across_body, legs_crossing, limb_under_clothing, round_body,
props) in a random pose, proportions, palette and style (ink, watercolour, flat_colour, scan, pencil), 192-320 px
a side. Ground truth: every pair of parts whose filled shapes overlap by >= 12 px, the nearer over the farther,
adjacent parts (joint overlaps) included, their union, and the foreground coverage.

Deterministic per (split, index). The train split uses seeds 0 .. TEST_SEED_BASE - 1, the held-out test split
TEST_SEED_BASE + index: tuning never sees a test seed. Classes cycle with the index and styles with index // 5,
so every 25 consecutive samples hold each class in each style once.
"""
from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from .characters import BEAR, DINO, LAMP_RIG, PERSON, Rig, bear, dinosaur, lamp, person, two_bone_ik
from .drawing import draw, make_look
from .geometry import part_outline
from .model import Character, scaled
from .occlusion import occlusion_pairs
from .styles import BEAR as BEAR_COLOURS
from .styles import DINOSAUR, GIRL, KID, LAMP, STYLES, Palette

CLASSES = ("arm_across_body", "legs_crossing", "limb_under_clothing", "round_body", "props")
STYLE_NAMES = ("ink", "watercolour", "flat_colour", "scan", "pencil")
SPLITS = ("train", "test")
TEST_SEED_BASE = 10_000_000  # test seeds start here; train indices must stay below it
MIN_SIZE, MAX_SIZE = 192, 320
MIN_EVIDENCE_PX = 40  # the class's defining occlusion must cover at least this many pixels
MAX_TRIES = 30


@dataclass
class Sample:
    """One keyframe of the dataset.

    image: (H, W, 3) uint8 RGB as a reader decodes it; joints, parents: the skeleton; pose: (J, 3) float64
    x, y px and z depth (larger = farther); occlusion: per mask (H, W) bool, the nearer part over the farther;
    pairs: per mask its front/back part names and bones, adjacent, joined, t_junctions (k, 2) px, t_stems (k, 2)
    unit directions of the back part's outline away from each junction;
    occlusion_union: (H, W) bool; foreground: (H, W) float32 coverage in [0, 1] (enclosed paper is 0).
    """

    image: np.ndarray
    joints: list[str]
    parents: list[int]
    pose: np.ndarray
    occlusion: list[np.ndarray]
    pairs: list[dict]
    occlusion_union: np.ndarray
    foreground: np.ndarray
    label: str
    style: str
    split: str
    index: int
    seed: int


def sample_seed(split: str, index: int) -> int:
    """The seed of sample `index` of a split: train 0 .. TEST_SEED_BASE - 1, test TEST_SEED_BASE + index."""
    if split not in SPLITS:
        raise ValueError(f"split {split!r}: use one of {SPLITS}")
    if index < 0 or (split == "train" and index >= TEST_SEED_BASE):
        raise ValueError(f"index {index} outside the {split} split (train indices < {TEST_SEED_BASE})")
    return index if split == "train" else TEST_SEED_BASE + index


def sample_class(index: int) -> str:
    """The class of sample `index` (cycles, so any 5 consecutive samples hold every class)."""
    return CLASSES[index % len(CLASSES)]


def sample_style(index: int) -> str:
    """The style of sample `index` (cycles with index // 5: 25 consecutive samples cover class x style)."""
    return STYLE_NAMES[(index // len(CLASSES)) % len(STYLE_NAMES)]


def make_sample(split: str, index: int) -> Sample:
    """Generate sample `index` of `split` (arrays only, nothing written)."""
    seed = sample_seed(split, index)
    label, style_name = sample_class(index), sample_style(index)
    for attempt in range(MAX_TRIES):
        rng = np.random.default_rng([seed, attempt])
        size = (int(rng.integers(MIN_SIZE, MAX_SIZE + 1)), int(rng.integers(MIN_SIZE, MAX_SIZE + 1)))
        char, pose, palette, evidence = POSERS[label](rng, seed)
        placed = _fit(char, pose, size, rng)
        if placed is None:
            continue
        char, pose = placed
        style = STYLES[style_name]
        if style_name == "scan" and rng.random() < 0.5:  # a photographed colour drawing instead of ink
            style = replace(style, fill="flat", line="shade")
        drawing = draw(char, pose, size, make_look(style, palette, size, seed))
        occ = occlusion_pairs(char, pose, drawing.coverage)
        if not any(evidence(char, o) and o.mask.sum() >= MIN_EVIDENCE_PX for o in occ):
            continue
        pairs = [_pair(char, pose, o) for o in occ]
        union = np.zeros(size, bool)
        for o in occ:
            union |= o.mask
        return Sample(drawing.rgb, list(char.joints), list(char.parents), pose, [o.mask for o in occ], pairs,
                      union, drawing.union, label, style_name, split, index, seed)
    raise RuntimeError(f"{split} sample {index} ({label}): no pose with the class's occlusion in {MAX_TRIES} tries")


def samples(split: str, n: int, start: int = 0) -> Iterator[Sample]:
    """Samples start .. start + n - 1 of a split, generated one at a time (for a training loop)."""
    for i in range(start, start + n):
        yield make_sample(split, i)


def _pair(char: Character, pose: np.ndarray, o) -> dict:
    """JSON-ready description of one occlusion mask."""
    bones = char.bones
    depth = lambda b: round(float(0.5 * (pose[bones[b][0], 2] + pose[bones[b][1], 2])), 4)  # noqa: E731
    return {"front_part": char.part_name(o.front), "back_part": char.part_name(o.back), "front_bone": o.front,
            "back_bone": o.back, "front_joints": list(bones[o.front]), "back_joints": list(bones[o.back]),
            "front_depth": depth(o.front), "back_depth": depth(o.back), "adjacent": o.adjacent, "joined": o.joined,
            "pixels": int(o.mask.sum()), "t_junctions": [[round(float(x), 1), round(float(y), 1)] for x, y in o.junctions],
            "t_stems": [[round(float(x), 3), round(float(y), 3)] for x, y in o.stems]}


# ----------------------------------------------------------------------------- placing a character in the frame

def _fit(char: Character, pose: np.ndarray, size: tuple[int, int], rng: np.random.Generator
         ) -> tuple[Character, np.ndarray] | None:
    """Scale the character and pose (built around 256 px) so their outlines fill 55-85% of the frame,
    centred with some jitter; None when the shape is degenerate."""
    lo, hi = _extent(char, pose)
    span = hi - lo
    if np.any(span < 4):
        return None
    h, w = size
    k = rng.uniform(0.55, 0.85) * min(w / span[0], h / span[1])
    room = np.array([w, h]) - k * span
    offset = np.array([rng.uniform(0.25, 0.75), rng.uniform(0.25, 0.75)]) * room - k * lo
    out = pose.copy()
    out[:, :2] = k * pose[:, :2] + offset
    return scaled(char, k), out


def _extent(char: Character, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(2,) min and max corner (px) of every drawn part's outline, with room for the line."""
    pts = [part_outline(char.parts[c], pose[p, :2], pose[c, :2])[0] for p, c in char.bones
           if char.parts[c].shape != "none"]
    allp = np.concatenate(pts)
    return allp.min(0) - 3, allp.max(0) + 3


# ----------------------------------------------------------------------------- random characters per class

def _palette(base: Palette, rng: np.random.Generator) -> Palette:
    """The base palette with every colour's brightness and saturation jittered (a different felt-tip set)."""
    out = {}
    for m, v in base.items():
        rgb = np.asarray(v[:3], float)
        grey = rgb.mean()
        rgb = grey + (rgb - grey) * rng.uniform(0.7, 1.2)
        rgb = np.clip(rgb * rng.uniform(0.9, 1.06), 0, 255)
        out[m] = tuple(int(round(x)) for x in rgb) + tuple(v[3:])
    return out


def _lengths(rig: Rig, rng: np.random.Generator, spread: float = 0.12) -> dict[int, float]:
    """Every bone length of a rig times a random factor in [1 - spread, 1 + spread] (proportions)."""
    return {c: v * rng.uniform(1 - spread, 1 + spread) for c, v in rig.length.items()}


def _jitter(rig: Rig, rng: np.random.Generator, deg: float, steady: tuple[int, ...] = ()) -> dict[int, float]:
    """Rest angles with Gaussian noise of `deg` degrees (a third of it on the `steady` bones: body, neck)."""
    return {c: a + rng.normal(0, deg / 3 if c in steady else deg) for c, a in rig.rest.items()}


def _person(rng: np.random.Generator, seed: int, skirt: bool) -> tuple[Character, Palette, dict[int, float], float]:
    """A random person, its palette, bone lengths and girth."""
    girth = rng.uniform(0.85, 1.2)
    char = person(seed, skirt=skirt, girth=girth, sleeves=bool(rng.random() < 0.7))
    return char, _palette(GIRL if rng.random() < 0.5 else KID, rng), _lengths(PERSON, rng), girth


def _pose_arm_across(rng: np.random.Generator, seed: int):
    """A person with one forearm across the torso, in front of it (mostly) or behind it."""
    char, palette, length, _ = _person(rng, seed, skirt=bool(rng.random() < 0.3))
    angles = _jitter(PERSON, rng, 6)
    base = PERSON.pose((0.0, 0.0), angles, length=length)
    side = rng.choice([0, 1])  # 0: the right arm (image left), 1: the left arm
    sh, el, ha = (3, 4, 5) if side == 0 else (6, 7, 8)
    pelvis, neck = base[0, :2], base[1, :2]
    along = rng.uniform(0.3, 0.75)
    across = (1 if side == 0 else -1) * rng.uniform(0, 14)  # past the middle, toward the other side
    target = pelvis + along * (neck - pelvis) + np.array([across, 0.0])
    best = None
    for bend in (1, -1):  # the elbow away from the body looks natural
        a1, a2 = two_bone_ik(base[sh, :2], target, length[el], length[ha], bend)
        elbow = base[sh, :2] + length[el] * np.array([math.cos(math.radians(a1)), math.sin(math.radians(a1))])
        score = abs(elbow[0] - pelvis[0])
        if best is None or score > best[0]:
            best = (score, a1, a2)
    angles[el], angles[ha] = best[1], best[2]
    front = rng.random() < 0.75
    z = {sh: -0.5, el: -1.0, ha: -1.1} if front else {sh: 0.5, el: 1.0, ha: 1.1}
    pose = PERSON.pose((0.0, 0.0), angles, z=z, length=length)
    arm = {f"{'rl'[side]}_forearm", f"{'rl'[side]}_upper_arm"}

    def evidence(ch: Character, o) -> bool:  # that arm over (or under) the top
        names = {ch.part_name(o.front), ch.part_name(o.back)}
        return bool(names & arm) and "top" in names
    return char, pose, palette, evidence


def _pose_legs_crossing(rng: np.random.Generator, seed: int):
    """A person whose shins (and maybe thighs) cross, one leg in front of the other."""
    char, palette, length, _ = _person(rng, seed, skirt=bool(rng.random() < 0.2))
    angles = _jitter(PERSON, rng, 5)
    angles[10], angles[14] = rng.uniform(78, 90), rng.uniform(90, 102)  # thighs toward each other
    angles[11], angles[15] = rng.uniform(58, 80), rng.uniform(100, 122)  # shins cross
    angles[12], angles[16] = angles[11] + rng.uniform(40, 70), angles[15] - rng.uniform(40, 70)
    right_front = rng.random() < 0.5
    z = {10: -0.8, 11: -0.8, 12: -0.9} if right_front else {14: -0.8, 15: -0.8, 16: -0.9}
    pose = PERSON.pose((0.0, 0.0), angles, z=z, length=length)
    legs = {"r_shin", "l_shin", "r_thigh", "l_thigh", "r_boot", "l_boot"}

    def evidence(ch: Character, o) -> bool:  # a part of one leg over a part of the other
        front, back = ch.part_name(o.front), ch.part_name(o.back)
        return {front, back} <= legs and front[0] != back[0]
    return char, pose, palette, evidence


def _pose_under_clothing(rng: np.random.Generator, seed: int):
    """A person in a skirt (or a long coat of the top's colour) that hides the tops of the thighs."""
    char, palette, length, _ = _person(rng, seed, skirt=True)
    if rng.random() < 0.35:  # a long coat: the skirt in the top's colour
        palette = {**palette, "skirt": palette["top"]}
    length[17] = PERSON.length[17] * rng.uniform(0.9, 1.4)
    angles = _jitter(PERSON, rng, 8)
    angles[10], angles[14] = rng.uniform(88, 120), rng.uniform(60, 92)  # legs apart or walking
    pose = PERSON.pose((0.0, 0.0), angles, length=length)
    evidence = lambda ch, o: ch.part_name(o.front) == "skirt" and "thigh" in ch.part_name(o.back)  # noqa: E731
    return char, pose, palette, evidence


def _pose_round_body(rng: np.random.Generator, seed: int):
    """A dinosaur or a bear: limbs over (or under) a big round belly."""
    if rng.random() < 0.55:
        rig, char, palette = DINO, dinosaur(seed, girth=rng.uniform(0.85, 1.15)), DINOSAUR
        steady = (1, 2, 3)  # body, neck, head
    else:
        rig, char, palette = BEAR, bear(seed, girth=rng.uniform(0.85, 1.15)), BEAR_COLOURS
        steady = (1, 2, 3, 4)  # body, head, ears
    angles = _jitter(rig, rng, 14, steady)
    pose = rig.pose((0.0, 0.0), angles, length=_lengths(rig, rng, 0.1))
    evidence = lambda ch, o: not o.adjacent and "body" in (ch.part_name(o.front), ch.part_name(o.back))  # noqa: E731
    return char, pose, _palette(palette, rng), evidence


def _pose_props(rng: np.random.Generator, seed: int):
    """A desk lamp bent at random: arms overlapping at the hinges, sometimes the shade over the base."""
    char = lamp(seed, girth=rng.uniform(0.8, 1.3))
    angles = {1: 180.0, 2: rng.uniform(-120, -45), 3: 0.0, 4: 0.0}
    angles[3] = angles[2] + rng.uniform(60, 150)  # the upper arm folds back over the lower
    angles[4] = angles[3] + rng.uniform(-40, 80)
    if rng.random() < 0.5:  # facing the other way
        angles = {c: 180.0 - a for c, a in angles.items()}
    z = {2: -0.2, 3: -0.4, 4: -0.6} if rng.random() < 0.7 else {2: -0.5, 3: -0.2, 4: -0.3}
    pose = LAMP_RIG.pose((0.0, 0.0), angles, z=z, length=_lengths(LAMP_RIG, rng, 0.2))
    evidence = lambda ch, o: True  # noqa: E731  (every lamp overlaps at its hinges)
    return char, pose, _palette(LAMP, rng), evidence


POSERS = {"arm_across_body": _pose_arm_across, "legs_crossing": _pose_legs_crossing,
          "limb_under_clothing": _pose_under_clothing, "round_body": _pose_round_body, "props": _pose_props}


# ----------------------------------------------------------------------------- files

def write_sample(sample: Sample, out_dir: Path) -> Path:
    """Write one sample folder: image.png, skeleton.json, fg.png, occ_union.png, occ_{i}.png, meta.json."""
    d = out_dir / f"{sample.split}_{sample.index:07d}"
    d.mkdir(parents=True, exist_ok=True)
    _png(d / "image.png", sample.image[..., ::-1])
    _png(d / "fg.png", np.round(np.clip(sample.foreground, 0, 1) * 255).astype(np.uint8))
    _png(d / "occ_union.png", np.where(sample.occlusion_union, 255, 0).astype(np.uint8))
    for i, m in enumerate(sample.occlusion):
        _png(d / f"occ_{i}.png", np.where(m, 255, 0).astype(np.uint8))
    skeleton = {"joints": sample.joints, "parents": sample.parents,
                "pose": [[round(float(v), 3) for v in row] for row in sample.pose]}
    (d / "skeleton.json").write_text(json.dumps(skeleton) + "\n")
    meta = {"class": sample.label, "style": sample.style, "split": sample.split, "index": sample.index,
            "seed": sample.seed, "size": list(sample.image.shape[:2]),
            "masks": [{"file": f"occ_{i}.png", **p} for i, p in enumerate(sample.pairs)]}
    (d / "meta.json").write_text(json.dumps(meta, indent=1) + "\n")
    return d


def _png(path: Path, img: np.ndarray) -> None:
    """Write an 8-bit PNG (grey, or BGR for OpenCV)."""
    if not cv2.imwrite(str(path), np.ascontiguousarray(img)):
        raise OSError(f"{path}: cannot write PNG")


# ----------------------------------------------------------------------------- command line

def _write_one(args: tuple[str, int, str]) -> str:
    """Generate and write one sample (a worker's task); returns its folder."""
    split, index, out = args
    return str(write_sample(make_sample(split, index), Path(out)))


def main(argv: list[str] | None = None) -> None:
    """python data_samples/occlusion_set.py --split test --n 60 --out DIR [--start 0] [--workers 2]."""
    import argparse
    import time
    from concurrent.futures import ProcessPoolExecutor

    ap = argparse.ArgumentParser(description="Write samples of the generated occlusion dataset, one folder each.")
    ap.add_argument("--split", choices=SPLITS, required=True)
    ap.add_argument("--n", type=int, required=True, help="number of samples")
    ap.add_argument("--start", type=int, default=0, help="first sample index")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--workers", type=int, default=1, help="processes (samples are independent)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    tasks = [(args.split, i, str(args.out)) for i in range(args.start, args.start + args.n)]
    t0 = time.perf_counter()
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers) as pool:
            list(pool.map(_write_one, tasks, chunksize=4))
    else:
        for t in tasks:
            _write_one(t)
    dt = time.perf_counter() - t0
    print(f"{args.n} {args.split} samples in {args.out}: {dt:.1f} s, {args.n / max(dt, 1e-9):.1f} samples/s "
          f"with {args.workers} worker(s)")
