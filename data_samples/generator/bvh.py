"""A small BVH reader for the 3D occlusion generator: the hierarchy, the motion, world joint positions per frame.

The project's own BVH parser (ops/motion/bvh.py, being written on another branch) was not committed when this
generator was written, so the generator reads the files itself. It covers what motion-capture clips use: ROOT,
JOINT and End Site blocks, OFFSET, CHANNELS with any order of X/Y/Z position and rotation channels (rotations
in degrees, applied in the order listed, as intrinsic rotations), MOTION with Frames and Frame Time.
Retargeting onto the generator's humanoid takes only bone directions (canonical_positions, humanoid_joints).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

# the generator's humanoid joints and the BVH joint names that drive them (first present wins): Mixamo-style
# (Hips, Spine.., RightArm, RightForeArm, RightUpLeg) and CMU-style (RightShoulder, RightElbow, RightHip) clips
HUMANOID_SOURCES: dict[str, tuple[str, ...]] = {
    "root": ("Hips",),
    "torso": ("Spine3", "Spine2", "Chest2", "Chest", "Spine1", "Spine"),
    "neck": ("Neck", "lowerneck", "Neck1"),
    "head": ("Head",),
    "right_shoulder": ("RightArm", "RightShoulder"),
    "right_elbow": ("RightForeArm", "RightElbow"),
    "right_hand": ("RightHand", "RightWrist"),
    "left_shoulder": ("LeftArm", "LeftShoulder"),
    "left_elbow": ("LeftForeArm", "LeftElbow"),
    "left_hand": ("LeftHand", "LeftWrist"),
    "right_hip": ("RightUpLeg", "RightHip"),
    "right_knee": ("RightLeg", "RightKnee"),
    "right_foot": ("RightFoot", "RightAnkle"),
    "right_toe": ("RightToeBase", "RightToe"),
    "left_hip": ("LeftUpLeg", "LeftHip"),
    "left_knee": ("LeftLeg", "LeftKnee"),
    "left_foot": ("LeftFoot", "LeftAnkle"),
    "left_toe": ("LeftToeBase", "LeftToe"),
}


@dataclass
class Motion:
    """A BVH clip: joint names, parents (-1 for the root), (J, 3) offsets, per joint its channel names, and
    (F, C) float64 channel values per frame; frame_time in seconds. End sites are joints named '<parent>_end'."""

    names: list[str]
    parents: list[int]
    offsets: np.ndarray
    channels: list[list[str]]
    frames: np.ndarray
    frame_time: float

    def world_positions(self, frame: int) -> np.ndarray:
        """(J, 3) float64 world positions of every joint at one frame (the file's units and axes)."""
        values = self.frames[frame]
        pos = np.zeros((len(self.names), 3))
        rot = np.zeros((len(self.names), 3, 3))
        k = 0
        for j, (p, chans) in enumerate(zip(self.parents, self.channels)):
            local = np.eye(3)
            shift = self.offsets[j].copy()
            for ch in chans:
                v = values[k]
                k += 1
                axis = "XYZ".index(ch[0])
                if ch.endswith("position"):
                    shift[axis] = self.offsets[j][axis] + v
                else:
                    local = local @ _axis_rotation(axis, np.radians(v))
            if p < 0:
                pos[j], rot[j] = shift, local
            else:
                pos[j] = pos[p] + rot[p] @ shift
                rot[j] = rot[p] @ local
        return pos


def _axis_rotation(axis: int, angle: float) -> np.ndarray:
    """(3, 3) rotation by `angle` radians about coordinate axis 0, 1 or 2."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(3)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def read_bvh(path: Path) -> Motion:
    """Parse a BVH file; ValueError naming the file and line on anything malformed."""
    path = Path(path)
    tokens = path.read_text().split()
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[list[str]] = []
    stack: list[int] = []
    i = 0

    def need(cond: bool, what: str) -> None:
        if not cond:
            raise ValueError(f"{path}: malformed BVH near token {i} ({what}); fix: export the clip as standard BVH")

    need(len(tokens) > 1 and tokens[0] == "HIERARCHY", "no HIERARCHY")
    i = 1
    pending = -1
    while i < len(tokens) and tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            names.append(tokens[i + 1])
            parents.append(stack[-1] if stack else -1)
            offsets.append([0.0, 0.0, 0.0])
            channels.append([])
            pending = len(names) - 1
            i += 2
        elif t == "End":
            need(bool(stack), "End Site outside a joint")
            names.append(f"{names[stack[-1]]}_end")
            parents.append(stack[-1])
            offsets.append([0.0, 0.0, 0.0])
            channels.append([])
            pending = len(names) - 1
            i += 2
        elif t == "{":
            need(pending >= 0, "brace without a joint")
            stack.append(pending)
            pending = -1
            i += 1
        elif t == "}":
            need(bool(stack), "unbalanced braces")
            stack.pop()
            i += 1
        elif t == "OFFSET":
            need(bool(stack), "OFFSET outside a joint")
            offsets[stack[-1]] = [float(v) for v in tokens[i + 1:i + 4]]
            i += 4
        elif t == "CHANNELS":
            need(bool(stack), "CHANNELS outside a joint")
            n = int(tokens[i + 1])
            chans = tokens[i + 2:i + 2 + n]
            need(all(c[0] in "XYZ" and c[1:] in ("position", "rotation") for c in chans), "unknown channel")
            channels[stack[-1]] = chans
            i += 2 + n
        else:
            need(False, f"unexpected {t!r}")
    need(i < len(tokens) and not stack and names, "no MOTION section")
    need(tokens[i + 1] == "Frames:" and tokens[i + 3] == "Frame" and tokens[i + 4] == "Time:", "bad MOTION header")
    n_frames, frame_time = int(tokens[i + 2]), float(tokens[i + 5])
    values = np.array([float(v) for v in tokens[i + 6:]], np.float64)
    n_chan = sum(len(c) for c in channels)
    need(n_chan > 0 and values.size >= n_frames * n_chan, "fewer values than Frames x channels")
    frames = values[: n_frames * n_chan].reshape(n_frames, n_chan)
    return Motion(names, parents, np.array(offsets, np.float64), channels, frames, frame_time)


def canonical_frame(motion: Motion) -> np.ndarray:
    """(3, 3) rows = the clip's body axes in its world: left (character's left), up, forward (left x up).

    Read from frame 0: up from the hips toward the head, left from the right hip toward the left hip."""
    p = motion.world_positions(0)
    idx = {n: j for j, n in enumerate(motion.names)}
    src = {k: next((idx[n] for n in v if n in idx), None) for k, v in HUMANOID_SOURCES.items()}
    if any(src[k] is None for k in ("root", "head", "left_hip", "right_hip")):
        raise ValueError("BVH clip lacks Hips, Head or the hip joints; fix: use a humanoid clip")
    up = p[src["head"]] - p[src["root"]]
    up /= np.linalg.norm(up)
    left = p[src["left_hip"]] - p[src["right_hip"]]
    left -= up * (left @ up)
    left /= np.linalg.norm(left)
    return np.stack([left, up, np.cross(left, up)])


def humanoid_joints(motion: Motion, frame: int, axes: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """{humanoid joint name: (3,) position} at one frame, in the clip's body axes (x left, y up, z forward),
    relative to the hips. Joints the clip lacks are missing from the dict."""
    axes = canonical_frame(motion) if axes is None else axes
    p = motion.world_positions(frame)
    idx = {n: j for j, n in enumerate(motion.names)}
    out = {}
    for name, sources in HUMANOID_SOURCES.items():
        j = next((idx[n] for n in sources if n in idx), None)
        if j is not None:
            out[name] = p[j]
    root = out["root"].copy()
    return {k: axes @ (v - root) for k, v in out.items()}


def clips(folder: Path | None) -> list[Path]:
    """The .bvh files of a folder, sorted (none when folder is None)."""
    return [] if folder is None else sorted(Path(folder).glob("*.bvh"))
