"""The character model: a skeleton whose bones carry drawn parts, and the texture strokes fixed on each part."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np


@dataclass(frozen=True)
class Part:
    """How one bone is drawn: shape, half-width (px), padding past the joints (px, ellipse), texture.

    shape: "capsule" | "ellipse" | "head" (ellipse centred on the child joint, half-axes pad along, radius across)
    | "taper" (half-width `radius` at the parent joint, `radius1` at the child)
    | "trapezoid" (straight sides from `radius` to `radius1`, hem bulging by `pad`) | "none" (not drawn).
    offset: shift of the shape across the bone (px, along the bone's left normal), e.g. a belly.
    material: palette key of the fill colour; name: the part's name in ground truth (default: child joint).
    """

    shape: str
    radius: float
    pad: float = 0.0
    texture: str = "stripes"
    radius1: float | None = None
    offset: float = 0.0
    material: str = "body"
    name: str = ""
    joined: bool = False  # drawn as one shape with the part on the parent bone: no outline where they overlap


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

    def joined(self, b1: int, b2: int) -> bool:
        """True when bone indices b1 and b2 are painted as one shape: at most two `joined` links apart along a
        chain (a thick tail's segments overlap their neighbour's neighbour too; farther ones cross visibly)."""
        if not hasattr(self, "_joined_pairs"):
            bone_of = {c: i for i, (_, c) in enumerate(self.bones)}  # child joint -> bone index
            links = {(i, bone_of[p]) for i, (p, c) in enumerate(self.bones) if self.parts[c].joined and p in bone_of}
            links |= {(b, a) for a, b in links}
            two = {(a, d) for a, b in links for c, d in links if b == c and a != d}
            self._joined_pairs = links | two
        return (b1, b2) in self._joined_pairs

    def part_name(self, bone: int) -> str:
        """Ground-truth name of the part on bone index `bone` (its own name, else "parent-child" joint names)."""
        p, c = self.bones[bone]
        return self.parts[c].name or f"{self.joints[p]}-{self.joints[c]}"


def scaled(char: Character, k: float) -> Character:
    """The same character with every radius, pad and offset multiplied by k (for larger frames)."""
    parts = {c: replace(p, radius=p.radius * k, pad=p.pad * k, offset=p.offset * k,
                        radius1=None if p.radius1 is None else p.radius1 * k) for c, p in char.parts.items()}
    return Character(char.joints, char.parents, parts, char.seed)


def make_texture(kind: str, rng: np.random.Generator) -> list:
    """Texture strokes in the bone frame (u along 0..1 parent->child, v across in radius units).

    Each stroke is ("line", (n, 2) uv points, width px), ("dot", (u, v), radius px),
    ("ring", (u, v), (radius px, width px)) or ("patch", (n, 2) uv polygon, material).
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
    else:
        strokes = _more_texture(kind, rng)
    return strokes


def _ellipse_uv(cu: float, cv: float, au: float, av: float, n: int = 24) -> np.ndarray:
    """(n, 2) uv polygon of an axis-aligned ellipse in the bone frame."""
    s = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.stack([cu + au * np.cos(s), cv + av * np.sin(s)], 1)


def _more_texture(kind: str, rng: np.random.Generator) -> list:
    """Strokes of the textures added for round bodies, clothes, fur and props (see make_texture)."""
    strokes: list = []
    if kind in ("belly", "tummy"):  # a paler belly patch (side view: toward +v; front view: centred),
        cv = 0.3 if kind == "belly" else 0.0  # its drawn edge, and shading strokes along its lower side
        belly = _ellipse_uv(0.48, cv, 0.4, 0.55)
        strokes.append(("patch", belly, "belly"))
        strokes.append(("line", np.vstack([belly, belly[:1]]), rng.uniform(1.0, 1.3)))
        for u in np.linspace(0.2, 0.42, int(rng.integers(4, 6))):  # hatching on the shaded lower side
            strokes.append(("line", np.array([[u, cv + 0.12], [u + 0.1, cv + 0.42]]), rng.uniform(0.8, 1.1)))
    elif kind == "crosshatch":  # shading on one side, not an occlusion contour
        for u in np.linspace(0.22, 0.7, int(rng.integers(4, 7))):
            strokes.append(("line", np.array([[u, 0.2], [u + 0.16, 0.75]]), rng.uniform(0.8, 1.1)))
            strokes.append(("line", np.array([[u + 0.16, 0.2], [u, 0.75]]), rng.uniform(0.8, 1.1)))
    elif kind == "fur":  # short flicks near both edges, pointing along the bone
        for _ in range(int(rng.integers(5, 9))):
            u, side = rng.uniform(0.15, 0.85), rng.choice([-1.0, 1.0])
            v0 = side * rng.uniform(0.35, 0.6)
            strokes.append(("line", np.array([[u, v0], [u + 0.05, v0 + side * 0.12], [u + 0.12, v0 + side * 0.16]]),
                            rng.uniform(0.8, 1.2)))
    elif kind == "spots":
        for _ in range(int(rng.integers(3, 6))):
            strokes.append(("dot", (rng.uniform(0.15, 0.85), rng.uniform(-0.5, 0.5)), rng.uniform(1.5, 2.6)))
    elif kind == "folds":  # cloth folds: two or three short curved lines
        for _ in range(int(rng.integers(2, 4))):
            u = rng.uniform(0.2, 0.8)
            v = np.linspace(0, rng.uniform(0.3, 0.6), 4) * rng.choice([-1.0, 1.0])
            strokes.append(("line", np.stack([u + 0.1 * v ** 2 + rng.uniform(-0.03, 0.03), v], 1), rng.uniform(0.8, 1.1)))
    elif kind == "boot_shaft":  # the lower part of a shin is the boot's shaft, with a line at its top
        strokes.append(("patch", np.array([[0.62, -1.4], [1.4, -1.4], [1.4, 1.4], [0.62, 1.4]]), "boots"))
        v = np.linspace(-1.0, 1.0, 5)
        strokes.append(("line", np.stack([0.62 + 0.04 * (1 - v ** 2), v], 1), 0.9))
    elif kind == "hair":  # bone runs neck -> top of head: hair covers the top, a face below it
        strokes.append(("patch", np.array([[0.62, -1.05], [0.8, -1.1], [1.0, -0.8], [1.12, 0.0], [1.0, 0.8],
                                           [0.8, 1.1], [0.62, 1.05], [0.7, 0.4], [0.74, -0.2]]), "hair"))
        strokes += [("dot", (0.5, -0.33), 1.6), ("dot", (0.5, 0.33), 1.6)]
        v = np.linspace(-0.28, 0.28, 7)
        strokes.append(("line", np.stack([0.28 + 0.07 * (v / 0.28) ** 2, v], 1), 1.2))
    elif kind == "face_front":  # a "head" part centred on its joint (u = 1): eyes above, snout and mouth below
        strokes += [("dot", (1.22, -0.33), 1.8), ("dot", (1.22, 0.33), 1.8), ("dot", (0.92, 0.0), 2.4)]
        v = np.linspace(-0.3, 0.3, 9)
        strokes.append(("line", np.stack([0.74 + 0.1 * (v / 0.3) ** 2, v], 1), 1.2))
    elif kind == "face_side":  # a side-view head from neck to snout: one eye, a mouth line
        strokes.append(("dot", (0.62, -0.32), 1.8))
        strokes.append(("line", np.array([[0.6, 0.35], [0.8, 0.3], [0.98, 0.2]]), 1.1))
        strokes.append(("dot", (1.0, -0.1), 1.0))  # nostril
    elif kind == "hinge":  # a pivot ring at each end of a lamp arm
        strokes += [("ring", (0.0, 0.0), (2.8, 1.0)), ("ring", (1.0, 0.0), (2.8, 1.0))]
        strokes.append(("line", np.array([[0.15, 0.0], [0.85, 0.0]]), 0.9))
    elif kind == "shade":  # ribs along a lamp shade and a band at its rim
        for v in (-0.5, 0.0, 0.5):
            strokes.append(("line", np.array([[0.15, v], [0.85, v * 2.2]]), 1.0))
        strokes.append(("line", np.array([[0.9, -2.6], [0.9, 2.6]]), 1.3))
    elif kind == "tail_tip":  # a pale tip patch at the end of the last tail segment, plus fur
        strokes.append(("patch", np.array([[0.55, -1.3], [1.4, -1.3], [1.4, 1.3], [0.55, 1.3], [0.45, 0.0]]), "tip"))
        strokes.append(("line", np.array([[0.2, 0.4], [0.3, 0.55], [0.4, 0.6]]), 1.0))
    elif kind != "none":
        raise ValueError(f"unknown texture {kind!r}")
    return strokes
