"""Biovision Hierarchy (BVH) motion capture: the parser and forward kinematics.

A small parser of our own rather than a PyPI library: `bvhio` evaluates frames joint by joint through PyGLM
objects and `pybvh` pulls in matplotlib, while the format is a page of grammar. Forward kinematics is
vectorised over frames with scipy's rotations.

Conventions, as most exporters write them: a joint's Euler channels are intrinsic rotations applied in the
order they are listed (`Zrotation Xrotation Yrotation`: R = Rz Rx Ry), in degrees; position channels replace
the joint's OFFSET (the root's offset is usually zero); `End Site` blocks carry no channels and are not joints.
Joint names keep the file's spelling; `base_name` strips a namespace prefix such as `mixamorig:`.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ops.errors import ShotError

MAX_BVH_BYTES = 256 * 2**20  # an hour of 120 fps capture of a 60-joint actor is about 200 MB
MAX_BVH_JOINTS = 512
ROTATIONS = {"Xrotation": "X", "Yrotation": "Y", "Zrotation": "Z"}
POSITIONS = {"Xposition": 0, "Yposition": 1, "Zposition": 2}


@dataclass(frozen=True)
class BVH:
    """A parsed clip: the hierarchy and every frame's channel values."""

    names: tuple[str, ...]  # joint names as written in the file, parents before children
    parents: np.ndarray  # (J,) int64, -1 for the root
    offsets: np.ndarray  # (J, 3) float64 rest offset of each joint from its parent, BVH units
    channels: tuple[tuple[str, ...], ...]  # per joint its channel names in file order
    motion: np.ndarray  # (F, C) float64 channel values per frame, columns in joint then channel order
    frame_time: float  # seconds per frame

    @property
    def frames(self) -> int:
        """Number of frames F."""
        return int(self.motion.shape[0])

    def index(self, name: str) -> int:
        """Joint index of a name, matched after stripping namespace prefixes; KeyError if absent."""
        key = base_name(name)
        for i, n in enumerate(self.names):
            if base_name(n) == key:
                return i
        raise KeyError(name)

    def world_positions(self, frames: np.ndarray | None = None) -> np.ndarray:
        """(F', J, 3) float64 joint positions in the file's world frame at the given frame indices (all: None)."""
        return forward_kinematics(self, frames)


def base_name(name: str) -> str:
    """A BVH joint name without its namespace prefix: 'mixamorig:LeftArm' -> 'LeftArm'."""
    return name.rsplit(":", 1)[-1].strip()


def _error(file: Path, field: str, problem: str) -> ShotError:
    return ShotError(file, field, problem, "give a BVH file as motion-capture tools export it (HIERARCHY, then MOTION)")


def parse_bvh(path: str | Path) -> BVH:
    """Read a BVH file; ShotError naming the file and the section on any malformed input."""
    file = Path(path)
    try:
        if file.stat().st_size > MAX_BVH_BYTES:
            raise _error(file, "BVH", f"file is larger than {MAX_BVH_BYTES // 2**20} MB")
        text = file.read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        raise ShotError(file, "BVH", f"cannot read ({e.strerror or e})", "give the path of a readable .bvh file") from None
    return parse_bvh_text(text, file)


def parse_bvh_text(text: str, file: str | Path = "<bvh>") -> BVH:
    """Parse BVH text (file: named in errors)."""
    file = Path(file)
    head, sep, tail = text.partition("MOTION")
    if not sep or "HIERARCHY" not in head:
        raise _error(file, "HIERARCHY", "no HIERARCHY section followed by a MOTION section")
    tokens = head.split("HIERARCHY", 1)[1].replace("{", " { ").replace("}", " } ").split()
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    stack: list[int] = []  # open joints; -2 marks an End Site block
    i = 0

    def number(k: int) -> float:
        try:
            return float(tokens[k])
        except (IndexError, ValueError):
            raise _error(file, "HIERARCHY", f"expected a number near token {k} ({' '.join(tokens[max(0, k - 3):k + 1])!r})") from None

    while i < len(tokens):
        tok = tokens[i]
        if tok in ("ROOT", "JOINT"):
            if tok == "ROOT" and names:
                raise _error(file, "HIERARCHY", "more than one ROOT")
            if tok == "JOINT" and (not stack or stack[-1] < 0):
                raise _error(file, "HIERARCHY", "a JOINT outside any joint's braces")
            if i + 2 >= len(tokens) or tokens[i + 2] != "{":
                raise _error(file, "HIERARCHY", f"{tok} needs a name and an opening brace")
            name = tokens[i + 1]
            if name in names:
                raise _error(file, "HIERARCHY", f"joint name {name!r} appears twice")
            names.append(name)
            parents.append(stack[-1] if stack else -1)
            offsets.append([0.0, 0.0, 0.0])
            channels.append(())
            stack.append(len(names) - 1)
            i += 3
        elif tok == "End":
            if i + 2 >= len(tokens) or tokens[i + 1] != "Site" or tokens[i + 2] != "{":
                raise _error(file, "HIERARCHY", "'End' must be followed by 'Site {'")
            stack.append(-2)
            i += 3
        elif tok == "OFFSET":
            if not stack:
                raise _error(file, "HIERARCHY", "OFFSET outside a joint")
            values = [number(i + 1), number(i + 2), number(i + 3)]
            if stack[-1] >= 0:
                offsets[stack[-1]] = values
            i += 4
        elif tok == "CHANNELS":
            if not stack or stack[-1] < 0:
                raise _error(file, "HIERARCHY", "CHANNELS outside a joint")
            n = int(number(i + 1))
            chans = tuple(tokens[i + 2:i + 2 + n])
            bad = [c for c in chans if c not in ROTATIONS and c not in POSITIONS]
            if len(chans) != n or bad:
                raise _error(file, "HIERARCHY", f"joint {names[stack[-1]]!r}: unknown channels {bad or chans}")
            channels[stack[-1]] = chans
            i += 2 + n
        elif tok == "}":
            if not stack:
                raise _error(file, "HIERARCHY", "unbalanced closing brace")
            stack.pop()
            i += 1
        else:
            raise _error(file, "HIERARCHY", f"unexpected token {tok!r}")
        if len(names) > MAX_BVH_JOINTS:
            raise _error(file, "HIERARCHY", f"more than {MAX_BVH_JOINTS} joints")
    if stack or not names:
        raise _error(file, "HIERARCHY", "unbalanced braces or no ROOT joint")

    lines = [ln.strip() for ln in tail.strip().splitlines() if ln.strip()]
    try:
        n_frames = int(lines[0].split(":", 1)[1]) if lines[0].lower().startswith("frames") else -1
        frame_time = float(lines[1].split(":", 1)[1]) if lines[1].lower().startswith("frame time") else -1.0
    except (IndexError, ValueError):
        n_frames, frame_time = -1, -1.0
    if n_frames < 1 or not frame_time > 0:
        raise _error(file, "MOTION", "needs 'Frames: N' (N >= 1) and 'Frame Time: seconds' (> 0)")
    width = sum(len(c) for c in channels)
    rows = lines[2:2 + n_frames]
    if len(rows) < n_frames:
        raise _error(file, "MOTION", f"'Frames: {n_frames}' but only {len(rows)} frame lines")
    try:
        motion = np.array([[float(v) for v in r.split()] for r in rows], dtype=np.float64)
    except ValueError:
        raise _error(file, "MOTION", "a frame line holds something that is not a number") from None
    if motion.ndim != 2 or motion.shape[1] != width:
        got = sorted({len(r.split()) for r in rows})[:3]
        raise _error(file, "MOTION", f"frame lines have {got} values, the hierarchy declares {width} channels")
    if not np.isfinite(motion).all():
        raise _error(file, "MOTION", "contains NaN or infinite values")
    return BVH(tuple(names), np.asarray(parents, np.int64), np.asarray(offsets, np.float64), tuple(channels),
               motion, frame_time)


def forward_kinematics(bvh: BVH, frames: np.ndarray | None = None) -> np.ndarray:
    """(F', J, 3) float64 world joint positions, BVH units, at the given frame indices (None: every frame)."""
    motion = bvh.motion if frames is None else bvh.motion[np.asarray(frames, np.int64)]
    F, J = motion.shape[0], len(bvh.names)
    pos = np.zeros((F, J, 3))
    rots: list[Rotation] = []
    col = 0
    for j in range(J):
        chans = bvh.channels[j]
        values = motion[:, col:col + len(chans)]
        col += len(chans)
        local_t = np.broadcast_to(bvh.offsets[j], (F, 3)).copy()
        rot_axes = "".join(ROTATIONS[c] for c in chans if c in ROTATIONS)
        for k, c in enumerate(chans):
            if c in POSITIONS:
                if not any(cc in POSITIONS for cc in chans[:k]):
                    local_t[:] = 0.0  # position channels replace the offset
                local_t[:, POSITIONS[c]] = values[:, k]
        if rot_axes:
            angles = values[:, [k for k, c in enumerate(chans) if c in ROTATIONS]]
            local_r = Rotation.from_euler(rot_axes, angles, degrees=True)  # upper case: intrinsic, file order
        else:
            local_r = Rotation.identity(F)
        p = int(bvh.parents[j])
        if p < 0:
            rots.append(local_r)
            pos[:, j] = local_t
        else:
            rots.append(rots[p] * local_r)
            pos[:, j] = pos[:, p] + rots[p].apply(local_t)
    return pos


def frame_slice(spec: str | None, n_frames: int, frame_time: float, file: str | Path = "--bvh-frames",
                target_fps: float = 30.0) -> np.ndarray:
    """(F',) int64 frame indices of a Python slice 'START:END:STEP' of n_frames (None: every frame, thinned to
    at most target_fps so a 120 fps capture does not become four times as many drawings)."""
    if spec is None:
        step = max(1, int(round(1.0 / (target_fps * frame_time))))
        return np.arange(0, n_frames, step, dtype=np.int64)
    parts = spec.split(":")
    try:
        if len(parts) > 3:
            raise ValueError
        values = [int(p) if p.strip() else None for p in parts] + [None] * (3 - len(parts))
    except ValueError:
        raise ShotError(file, "--bvh-frames", f"{spec!r} is not START:END:STEP", "write e.g. 0:120:2 (any part may be empty)") from None
    if values[2] is not None and values[2] <= 0:
        raise ShotError(file, "--bvh-frames", f"step {values[2]} is not positive", "give a step of 1 or more")
    idx = np.arange(n_frames, dtype=np.int64)[slice(*values)]
    if idx.size == 0:
        raise ShotError(file, "--bvh-frames", f"{spec!r} selects no frame of the clip's {n_frames}",
                        f"give a slice inside 0:{n_frames}")
    return idx
