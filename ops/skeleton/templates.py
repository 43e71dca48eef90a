"""Skeleton templates a new shot starts from: joint names, parents and default positions in the unit box.

`humanoid` uses AnimatedDrawings' 16 joint names and hierarchy (its char_cfg.yaml skeleton), so its retarget
configs apply unchanged; `quadruped` is a side-view four-legged animal with a tail. A user's skeleton file
(`{"joints": [...], "parents": [...], "positions": [[u, v], ...]}`, positions optional) is a template too.

Default positions are (u, v) in the unit box of the character's bounding box: u right, v down, both in [0, 1];
they are a starting point for placement (ops/skeleton/placement.py) and for the editor's "apply a template".
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ops.errors import ShotError
from ops.shotio.load import parse_skeleton  # the shot loader's validation: unique names, one root, no cycle


@dataclass(frozen=True)
class SkeletonTemplate:
    """A named skeleton with default joint positions in the unit box."""

    name: str
    joints: tuple[str, ...]
    parents: tuple[int, ...]  # index of each joint's parent, -1 for the single root
    positions: np.ndarray  # (J, 2) float64 (u, v) in [0, 1]^2 of the character's bounding box, v down

    def to_json(self) -> dict:
        """The template as a skeleton file: {"joints", "parents", "positions"}."""
        return {"joints": list(self.joints), "parents": list(self.parents),
                "positions": np.round(self.positions, 4).tolist()}


def _template(name: str, rows: list[tuple[str, str | None, float, float]]) -> SkeletonTemplate:
    """Template from (joint, parent name or None, u, v) rows in parent-before-child order."""
    names = [r[0] for r in rows]
    parents = tuple(-1 if r[1] is None else names.index(r[1]) for r in rows)
    return SkeletonTemplate(name, tuple(names), parents, np.array([[r[2], r[3]] for r in rows], np.float64))


# AnimatedDrawings' humanoid, facing the viewer: the character's right side is on the image's left. `root` and
# `hip` share a spot (a zero-length bone), as in every AnimatedDrawings character.
HUMANOID = _template("humanoid", [
    ("root", None, 0.50, 0.60), ("hip", "root", 0.50, 0.60), ("torso", "hip", 0.50, 0.38),
    ("neck", "torso", 0.50, 0.20),
    ("right_shoulder", "torso", 0.36, 0.34), ("right_elbow", "right_shoulder", 0.22, 0.42),
    ("right_hand", "right_elbow", 0.08, 0.50),
    ("left_shoulder", "torso", 0.64, 0.34), ("left_elbow", "left_shoulder", 0.78, 0.42),
    ("left_hand", "left_elbow", 0.92, 0.50),
    ("right_hip", "root", 0.40, 0.62), ("right_knee", "right_hip", 0.37, 0.80), ("right_foot", "right_knee", 0.34, 0.97),
    ("left_hip", "root", 0.60, 0.62), ("left_knee", "left_hip", 0.63, 0.80), ("left_foot", "left_knee", 0.66, 0.97),
])

# A four-legged animal in side view, head to the image's right; "near" legs face the viewer, "far" legs behind.
QUADRUPED = _template("quadruped", [
    ("root", None, 0.30, 0.40), ("spine", "root", 0.50, 0.38), ("chest", "spine", 0.68, 0.38),
    ("neck", "chest", 0.80, 0.25), ("head", "neck", 0.92, 0.12),
    ("tail", "root", 0.15, 0.32), ("tail_tip", "tail", 0.02, 0.20),
    ("front_near_shoulder", "chest", 0.70, 0.50), ("front_near_knee", "front_near_shoulder", 0.72, 0.75),
    ("front_near_foot", "front_near_knee", 0.72, 0.98),
    ("front_far_shoulder", "chest", 0.64, 0.50), ("front_far_knee", "front_far_shoulder", 0.64, 0.75),
    ("front_far_foot", "front_far_knee", 0.63, 0.98),
    ("back_near_hip", "root", 0.32, 0.52), ("back_near_knee", "back_near_hip", 0.30, 0.75),
    ("back_near_foot", "back_near_knee", 0.33, 0.98),
    ("back_far_hip", "root", 0.26, 0.52), ("back_far_knee", "back_far_hip", 0.24, 0.75),
    ("back_far_foot", "back_far_knee", 0.26, 0.98),
])

TEMPLATES: dict[str, SkeletonTemplate] = {t.name: t for t in (HUMANOID, QUADRUPED)}


def load_template(name_or_file: str | Path) -> SkeletonTemplate:
    """A built-in template by name, or a skeleton file; ShotError naming the file and field on bad input.

    A file without `positions` gets positions spread down its hierarchy (root at the top centre, each
    generation a row lower, siblings side by side) so that every joint starts at a distinct spot.
    """
    if str(name_or_file) in TEMPLATES:
        return TEMPLATES[str(name_or_file)]
    path = Path(name_or_file)
    if not path.is_file():
        raise ShotError(path, "skeleton", f"is neither a built-in template ({', '.join(TEMPLATES)}) nor a file",
                        "give humanoid, quadruped or the path of a skeleton JSON file")
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise ShotError(path, "skeleton", f"cannot be read as JSON ({type(e).__name__})",
                        'write {"joints": [...], "parents": [...]}') from None
    if not isinstance(data, dict):
        raise ShotError(path, "skeleton", "top level is not an object", 'write {"joints": [...], "parents": [...]}')
    skeleton = parse_skeleton({"skeleton": data}, path)
    J = len(skeleton.joints)
    if data.get("positions") is None:
        positions = _spread(skeleton.parents)
    else:
        try:
            positions = np.asarray(data["positions"], np.float64)
        except (TypeError, ValueError):
            positions = np.zeros(0)
        if positions.shape != (J, 2) or not np.isfinite(positions).all() or (positions < 0).any() or (positions > 1).any():
            raise ShotError(path, "positions", f"must be {J} pairs [u, v] in [0, 1] (one per joint)",
                            "give each joint's position in the unit box, or leave positions out")
    return SkeletonTemplate(path.stem, skeleton.joints, tuple(int(p) for p in skeleton.parents), positions)


def _spread(parents: np.ndarray) -> np.ndarray:
    """(J, 2) unit-box positions: depth in the hierarchy down v, leaves of each generation spread along u."""
    J = len(parents)
    depth = np.zeros(J, np.int64)
    for j in range(J):
        p, d = int(parents[j]), 0
        while p >= 0:
            p, d = int(parents[p]), d + 1
        depth[j] = d
    out = np.zeros((J, 2))
    for d in range(int(depth.max()) + 1):
        row = np.nonzero(depth == d)[0]
        out[row, 0] = (np.arange(len(row)) + 0.5) / len(row)
        out[row, 1] = (d + 0.5) / (depth.max() + 1)
    return out
