"""The v2 sample shots (docs/shot-format.md, version 2): sequences of 3 and 4 keys, and one-drawing shots.

Each is written like the v1 samples (write.py): the keyframes, ground truth at every output frame drawn at the
poses the loader computes from the key poses (its own C1 curve and easing, ops/shotio/motion.py), the
generator's exact T-junctions per key, and the occlusion ground truth per key. shot.json gives the key poses
only, so the loader's motion is what the ground truth shows.
"""
from __future__ import annotations

import json
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ops.shotio.motion import interpolate_motion

from .characters import DINO, PERSON, dinosaur, human_pose, humanoid, person
from .model import Character, scaled
from .occlusion import occlusion_pairs
from .poses import quantize
from .styles import DINOSAUR, GIRL
from .write import (
    _dump,
    _mask_png,
    _points,
    _pose_json,
    _write_drawing,
    _write_png,
    pair_record,
    shot_drawing,
    shot_look,
)

FORMAT_V2 = "inbetween-shot/2"


@dataclass
class SequenceSpec:
    """A v2 sample: N key poses at their output frames (N = 1: the drawing, then the poses it is moved through)."""

    name: str
    char: Character
    keys: tuple[np.ndarray, ...]  # (J, 3) key poses; for N = 1 the drawing's pose then the motion's poses
    key_frames: tuple[int, ...]  # output frame of each key; for N = 1 the frame of each pose of `keys`
    size: tuple[int, int]
    ease: tuple[str, ...] | None = None
    one_drawing: bool = False
    description: str = ""
    style: str | None = None
    palette: dict | None = None

    @property
    def n_frames(self) -> int:
        return self.key_frames[-1] + 1


def seq_arm_cross() -> SequenceSpec:
    """Three keys: the right forearm hangs, then crosses in front of the torso (the middle key), then is raised."""
    k, root = 1.25, (160.0, 178.0)
    keys = (human_pose(root, {4: 104, 5: 97}, scale=k), human_pose(root, {4: 100, 5: -12}, scale=k),
            human_pose(root, {4: 190, 5: 230}, scale=k))
    return SequenceSpec("seq_arm_cross", _scaled_humanoid(31, k), keys, (0, 8, 16), (320, 320),
                        description="3 keys: right forearm beside the body, crossing in front of the torso (key 1), "
                                    "raised out to the side (key 2)")


def seq_dino_step() -> SequenceSpec:
    """Four keys at uneven frames: the flat-colour dinosaur steps and swings its arm over its belly and back."""
    root = (124.0, 142.0)
    keys = (DINO.pose(root),
            DINO.pose(root, {4: 150, 5: 140, 8: 75, 9: -10, 11: 105, 12: 40}),
            DINO.pose(root, {1: -32, 2: -62, 3: 14, 4: 168, 5: 160, 6: 150, 8: 80, 9: 30, 14: 60, 15: 110, 16: 10}),
            DINO.pose(root, {4: 175, 5: 170, 6: 160, 8: 100, 9: 120, 18: 110, 19: 95, 20: 0}))
    return SequenceSpec("seq_dino_step", dinosaur(32), keys, (0, 6, 14, 20), (256, 256),
                        ease=("out", "linear", "in"), style="flat_colour", palette=DINOSAUR,
                        description="4 keys at frames 0, 6, 14, 20 (slow out of the first, slow in to the last): "
                                    "the dinosaur swings its near arm over its belly and steps")


def one_arm_swing() -> SequenceSpec:
    """One drawing (arm hanging) moved through a swing that carries the forearm across the body and out again."""
    root = (128.0, 142.0)
    poses = (human_pose(root, {4: 104, 5: 97}), human_pose(root, {4: 100, 5: -14}),
             human_pose(root, {4: 150, 5: 190}))
    return SequenceSpec("one_arm_swing", humanoid(33), poses, (0, 6, 12), (256, 256), one_drawing=True,
                        description="one drawing: the right forearm swings up across the torso (in front of it) "
                                    "and out to the side")


def one_girl_wave() -> SequenceSpec:
    """One watercolour drawing waving: her forearm passes in front of her top."""
    root = (128.0, 116.0)
    poses = (PERSON.pose(root, {4: 104, 5: 98, 7: 76, 8: 84}), PERSON.pose(root, {4: 100, 5: -14, 7: 72, 8: 80}))
    return SequenceSpec("one_girl_wave", person(34), poses, (0, 8), (256, 256), one_drawing=True,
                        style="watercolour", palette=GIRL,
                        description="one watercolour drawing: her right forearm comes across in front of her top")


def _scaled_humanoid(seed: int, k: float) -> Character:
    return scaled(humanoid(seed), k)


SEQUENCES = {"seq_arm_cross": seq_arm_cross, "seq_dino_step": seq_dino_step, "one_arm_swing": one_arm_swing,
             "one_girl_wave": one_girl_wave}


def sequence_poses(spec: SequenceSpec) -> np.ndarray:
    """(F, J, 3) poses at every output frame: the loader's motion through the quantized key poses."""
    keys = np.stack([quantize(k) for k in spec.keys])
    frames = np.asarray(spec.key_frames, np.float64)
    key_frames = (0,) if spec.one_drawing else spec.key_frames
    n_seg = 1 if spec.one_drawing else len(spec.keys) - 1
    return interpolate_motion(frames, keys, key_frames, spec.ease or ("linear",) * n_seg,
                              np.asarray(spec.char.parents, np.int64), spec.n_frames)


def write_sequence(spec: SequenceSpec, out_root: Path) -> Path:
    """Render and write one v2 shot directory under out_root; returns its path (replaced if present)."""
    d = out_root / spec.name
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    poses = sequence_poses(spec)
    look = shot_look(spec)
    frames = [shot_drawing(spec, p, look) for p in poses]
    ext = ".png" if frames[0].jpeg is None else ".jpg"
    for i, f in enumerate(frames):
        _write_drawing(d / "gt" / f"{i:04d}{ext}", f)
    key_frames = (0,) if spec.one_drawing else spec.key_frames
    names = []
    for k, f in enumerate(key_frames):
        names.append(f"key{k}{ext}")
        _write_drawing(d / names[-1], frames[f])
    junctions, records = [], []
    for k, f in enumerate(key_frames):
        pairs = occlusion_pairs(spec.char, poses[f], frames[f].coverage)
        junctions.append([p for o in pairs if not o.adjacent for p in _points(o.junctions)])
        _write_png(d / "gt_fg" / f"key{k}.png", np.round(np.clip(frames[f].union, 0, 1) * 255).astype(np.uint8))
        union = np.zeros(spec.size, bool)
        for i, o in enumerate(pairs):
            name = f"key{k}_pair{i}.png"
            _write_png(d / "gt_occ" / name, _mask_png(o.mask))
            records.append(pair_record(spec, o, k, poses[f], name))
            union |= o.mask
        _write_png(d / "gt_occ" / f"key{k}_union.png", _mask_png(union))
    (d / "gt_occ").mkdir(exist_ok=True)
    (d / "gt_occ" / "pairs.json").write_text(json.dumps(records, indent=1) + "\n")
    data: dict = {"format": FORMAT_V2, "keyframes": names}
    if not spec.one_drawing:
        data["key_frames"] = list(spec.key_frames)
    data["skeleton"] = {"joints": spec.char.joints, "parents": spec.char.parents}
    data["poses"] = [{"frame": int(f), "joints": _pose_json(p)} for f, p in zip(spec.key_frames, spec.keys)]
    if spec.ease:
        data["ease"] = list(spec.ease)
    data["t_junctions"] = junctions
    data["ground_truth"] = "gt"
    (d / "shot.json").write_text(_dump(data) + "\n")
    return d
