"""The 3D occlusion dataset: posed 3D bodies drawn in random styles, with occlusion truth from a depth buffer.

One sample is one keyframe: a body of one family (bodies3d.FAMILIES: round, thin, quadruped, props, creature)
in a pose from a BVH clip or a procedural one, seen from the front, three-quarter, the side or behind, drawn
in one style family (looks3d.STYLE_FAMILIES) with randomized line weight, breaks, fills and paper, 192-320 px a
side. Its skeleton is either every joint of the rig or the AnimatedDrawings-style subset a user would place.

Ground truth (the definition of the 2D generator's issue-15 truth, made exact): for every pair of bones whose
filled shapes overlap by >= MIN_OVERLAP_PX pixels, the region where both cover a pixel, with the bone whose
surface the rays enter first on most of it as the front; joint overlaps included (flagged `adjacent`). The
union of those regions is what the network learns.

Held out of training: the whole `creature` body family and the whole `crayon` style family (HELD_OUT_FAMILY,
HELD_OUT_STYLE): training draws only indices of the other combinations (train_indices); the test split's
held-out samples (held_out_indices) measure how the network does on a body and a style it never saw.
Deterministic per (split, index, the BVH clips given). Train seeds 0 .. TEST_SEED_BASE - 1, test seeds
TEST_SEED_BASE + index.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from .bodies3d import FAMILIES, Body, make_body
from .bvh import Motion, clips, read_bvh
from .junctions3d import depth_order, pair_junctions
from .looks3d import STYLE_FAMILIES, make_look3d
from .render3d import make_camera, on_camera, render

SPLITS = ("train", "test")
TEST_SEED_BASE = 10_000_000
HELD_OUT_FAMILY = "creature"
HELD_OUT_STYLE = "crayon"
MIN_SIZE, MAX_SIZE = 192, 320
MIN_OVERLAP_PX = 12  # smaller overlaps are rounding noise (the 2D generator's rule)
MIN_EVIDENCE_PX = 40  # most samples show an occlusion of two bones that share no joint, at least this large
NO_OCCLUSION_SHARE = 0.12  # ... the rest may show none (the network must also learn to mark nothing)
BVH_SHARE = 0.5  # people take their pose from a clip this often when clips are given
AD_SKELETON_SHARE = 0.6  # the skeleton a user places (AnimatedDrawings' joints) this often, else the whole rig
MAX_TRIES = 30


@dataclass
class Sample3D:
    """One keyframe: image (H, W, 3) uint8 RGB; joints, parents; pose (J, 3) float64 x, y px and depth (larger =
    farther); occlusion: per overlapping bone pair (H, W) bool; pairs: per mask front/back bone (Skeleton.bones
    index), their names, adjacent, pixels, front_share; occlusion_union (H, W) bool; foreground (H, W) float32
    coverage; label: body family; style: style family; view; motion ('bvh:<clip>' or 'procedural').
    Pairs of bones that share no joint also carry t_junctions (k, 2) px and t_stems (k, 2) unit
    (junctions3d.pair_junctions); adjacent pairs carry none."""

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
    view: str
    motion: str
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


def sample_family(index: int) -> str:
    """The body family of sample `index` (cycles with the index)."""
    return FAMILIES[index % len(FAMILIES)]


def sample_style(index: int) -> str:
    """The style family of sample `index` (cycles with index // 5: 35 consecutive samples hold every pair)."""
    return STYLE_FAMILIES[(index // len(FAMILIES)) % len(STYLE_FAMILIES)]


def held_out(index: int) -> str | None:
    """'body', 'style', 'both' or None: what of sample `index` training never sees."""
    body, style = sample_family(index) == HELD_OUT_FAMILY, sample_style(index) == HELD_OUT_STYLE
    return "both" if body and style else "body" if body else "style" if style else None


def train_indices(n: int, start: int = 0) -> list[int]:
    """The first n indices from `start` whose body and style families are both trained on."""
    out, i = [], start
    while len(out) < n:
        if held_out(i) is None:
            out.append(i)
        i += 1
    return out


def held_out_indices(kind: str, n: int, start: int = 0) -> list[int]:
    """The first n indices from `start` of a kind: 'body' (the held-out family, trained styles), 'style' (the
    held-out style, trained families) or 'seen' (neither held out: the in-distribution test)."""
    want = None if kind == "seen" else kind
    out, i = [], start
    while len(out) < n:
        if held_out(i) == want:
            out.append(i)
        i += 1
    return out


@lru_cache(maxsize=4)
def _motions(folder: str | None) -> tuple[tuple[str, Motion], ...]:
    """The BVH clips of a folder, read once per process."""
    return tuple((p.stem, read_bvh(p)) for p in clips(Path(folder) if folder else None))


def make_sample3d(split: str, index: int, bvh_dir: Path | str | None = None, family: str | None = None,
                  style: str | None = None) -> Sample3D:
    """Generate sample `index` of `split` (arrays only, nothing written). bvh_dir: a folder of .bvh clips that
    may pose the people; family, style: override the index's (for previews and tests)."""
    seed = sample_seed(split, index)
    family = family or sample_family(index)
    style = style or sample_style(index)
    motions = _motions(str(bvh_dir) if bvh_dir else None)
    for attempt in range(MAX_TRIES):
        rng = np.random.default_rng([seed, attempt, 3])
        size = (int(rng.integers(MIN_SIZE, MAX_SIZE + 1)), int(rng.integers(MIN_SIZE, MAX_SIZE + 1)))
        motion, frame, source = None, 0, "procedural"
        if motions and family in ("round", "thin", "props") and rng.random() < BVH_SHARE:
            name, motion = motions[int(rng.integers(len(motions)))]
            frame = int(rng.integers(len(motion.frames)))
            source = f"bvh:{name}"
        body = make_body(rng, family, motion, frame)
        if body.motion == "procedural":
            source = "procedural"
        camera = make_camera(rng)
        placed = on_camera(body, camera, size, rng)
        if placed is None:
            continue
        solids, marks, pose_cam, project = placed
        look = make_look3d(style, rng, scale=max(size) / 256.0)
        drawn = render(solids, marks, size, look, seed * 7 + attempt)
        fg = drawn.coverage >= 0.5
        if fg[0].any() or fg[-1].any() or fg[:, 0].any() or fg[:, -1].any():
            continue
        joints, parents, pose, bone_of = reduce_skeleton(body, pose_cam, project,
                                                         ad=bool(rng.random() < AD_SKELETON_SHARE))
        cover, entry = _merge(drawn.cover, drawn.entry, bone_of)
        masks, pairs = pair_truth(cover, entry, joints, parents, fg)
        evidence = any(not p["adjacent"] and p["pixels"] >= MIN_EVIDENCE_PX for p in pairs)
        if not evidence and rng.random() >= NO_OCCLUSION_SHARE:
            continue
        union = np.zeros(size, bool)
        for m in masks:
            union |= m
        pose[:, 2] = np.round(pose[:, 2], 3)
        return Sample3D(drawn.rgb, joints, parents, pose, masks, pairs, union, drawn.coverage.astype(np.float32),
                        family, style, camera.view, source, split, index, seed)
    raise RuntimeError(f"{split} sample {index} ({family}, {style}): no usable pose in {MAX_TRIES} tries")


def reduce_skeleton(body: Body, pose_cam: np.ndarray, project, ad: bool) -> tuple[list[str], list[int], np.ndarray,
                                                                                   dict[int, int]]:
    """The sample's skeleton: the whole rig, or (ad) only the joints an AnimatedDrawings-style skeleton has,
    placed where it places them (its neck at the head's centre). Returns joint names, parents, (J, 3) pose,
    and for every rig bone (keyed by its child joint) the index of the sample's bone that carries its bodies:
    a left-out joint's bodies go to the nearest kept bone up the chain."""
    keep = [j for j, n in enumerate(body.joints) if not ad or not body.ad_joints or n in body.ad_joints]
    new = {j: k for k, j in enumerate(keep)}

    def kept_ancestor(j: int) -> int:
        while j not in new:
            j = body.parents[j]
        return j

    parents = [-1 if body.parents[j] < 0 else new[kept_ancestor(body.parents[j])] for j in keep]
    pose = pose_cam[keep].copy()
    if ad:
        for name, p in body.ad_moves.items():
            if name in body.joints and body.joints.index(name) in new:
                pose[new[body.joints.index(name)]] = project(np.asarray(p)[None])[0]
    children = [k for k in range(len(keep)) if parents[k] >= 0]
    bone_index = {c: i for i, c in enumerate(children)}  # Skeleton.bones: child order
    root_bone = next(bone_index[c] for c in children if parents[c] == 0)
    bone_of = {}
    for c in range(len(body.joints)):
        if body.parents[c] < 0:
            continue
        k = new[kept_ancestor(c)]
        bone_of[c] = bone_index.get(k, root_bone)  # bodies above the root's children sit on its first bone
    return [body.joints[j] for j in keep], parents, pose, bone_of


def _merge(cover: dict, entry: dict, bone_of: dict[int, int]) -> tuple[dict, dict]:
    """Per-rig-bone shapes and depths merged onto the sample's bones (union, nearest)."""
    out_c: dict[int, np.ndarray] = {}
    out_e: dict[int, np.ndarray] = {}
    for b, m in cover.items():
        k = bone_of[b]
        out_c[k] = out_c[k] | m if k in out_c else m.copy()
        out_e[k] = np.minimum(out_e[k], entry[b]) if k in out_e else entry[b].copy()
    return out_c, out_e


def pair_truth(cover: dict, entry: dict, joints: list[str], parents: list[int], foreground: np.ndarray
               ) -> tuple[list[np.ndarray], list[dict]]:
    """Per pair of bones whose shapes overlap by >= MIN_OVERLAP_PX inside the (H, W) bool foreground: the (H, W)
    bool region and its description (front = the bone entered first on most of it; for bones that share no
    joint, the T-junctions of their outlines and their stems, junctions3d.pair_junctions)."""
    children = [c for c in range(len(parents)) if parents[c] >= 0]
    bones = [(parents[c], c) for c in children]
    name = lambda b: f"{joints[bones[b][0]]}-{joints[bones[b][1]]}"  # noqa: E731
    keys = sorted(cover)
    _, near_bone = depth_order(entry, foreground.shape)
    masks, pairs = [], []
    for i, a in enumerate(keys):
        for b in keys[i + 1:]:
            m = cover[a] & cover[b] & foreground
            n = int(m.sum())
            if n < MIN_OVERLAP_PX:
                continue
            ea, eb = entry[a][m], entry[b][m]
            both = np.isfinite(ea) & np.isfinite(eb)
            share = float((ea[both] < eb[both]).mean()) if both.any() else 0.5
            front, back = (a, b) if share >= 0.5 else (b, a)
            adjacent = bool(set(bones[a]) & set(bones[b]))
            pts, stems = (np.zeros((0, 2)), np.zeros((0, 2))) if adjacent else \
                pair_junctions(a, b, cover, near_bone)
            masks.append(m)
            pairs.append({"front_bone": int(front), "back_bone": int(back), "front_part": name(front),
                          "back_part": name(back), "adjacent": adjacent, "pixels": n,
                          "front_share": round(max(share, 1 - share), 3),
                          "t_junctions": [[round(float(x), 1), round(float(y), 1)] for x, y in pts],
                          "t_stems": [[round(float(x), 3), round(float(y), 3)] for x, y in stems]})
    return masks, pairs
