"""Stage warnings that name their subject (a joint, a bone, a T-junction, a region, a mask), in one line.

A stage's warnings are the input repairs and hints it made (stored in its provenance and metadata). Those
about one thing of the shot start with that thing, so a person reads them in the log and the editor shows
them at it (editor/warnings.py):

    joint 'r_hand' at (120.0, 88.5): lies far outside the foreground (9.2 px); fix: move it onto the drawing
    T-junction at (231.0, 277.0): was 33.4 px from every occlusion region; region 0 grown to meet it
    bones 'hip-knee' / 'hip-ankle' at (130.0, 210.0): bodies overlap ...; fix: give the joints different z ...

Form: `KIND[ NAME][ at (X, Y)]: PROBLEM[; fix: FIX]`. NAME is a quoted name (`'r_hand'`, several joined by
` / `) or an index; X, Y are keyframe pixels (x right, y down), where the warning belongs.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

# longest first: "occlusion region" must not be read as a shorter kind
KINDS = ("manual occlusion mask", "occlusion region", "part of the drawing", "T-junction", "handle", "joint",
         "bones", "bone")
_NUMBER = r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?"
_PATTERN = re.compile(
    rf"^(?P<kind>{'|'.join(map(re.escape, KINDS))})"
    r"(?: (?P<name>'.*?'(?: / '.*?')*|\d+))?"
    rf"(?: at \((?P<x>{_NUMBER}), (?P<y>{_NUMBER})\))?"
    r": (?P<problem>.+?)(?:; fix: (?P<fix>.+))?$")


@dataclass(frozen=True)
class Subject:
    """A parsed warning: what it is about, where, the problem and the fix (None when it gives none)."""

    kind: str  # one of KINDS
    names: tuple[str, ...]  # joint, bone or handle names; () when the subject is an index or unnamed
    index: int | None  # region or mask index within its keyframe
    at: tuple[float, float] | None  # keyframe pixels
    problem: str
    fix: str | None


def about(kind: str, problem: str, *, name: str | int | tuple[str, ...] | None = None,
          at: tuple[float, float] | np.ndarray | None = None, fix: str | None = None) -> str:
    """The warning line `KIND NAME at (X, Y): PROBLEM; fix: FIX` (name, at and fix optional).

    name: a joint, bone or handle name (quoted in the line), several names (joined by ' / '), or an index.
    at: (x, y) keyframe pixels where it belongs.
    """
    if kind not in KINDS:
        raise ValueError(f"warning kind {kind!r}: use one of {KINDS}")
    head = kind
    if isinstance(name, (int, np.integer)):
        head += f" {int(name)}"
    elif isinstance(name, str):
        head += f" '{name}'"
    elif name is not None:
        head += " " + " / ".join(f"'{n}'" for n in name)
    if at is not None:
        head += f" at ({float(at[0]):.1f}, {float(at[1]):.1f})"
    return f"{head}: {problem}" + (f"; fix: {fix}" if fix else "")


def parse(text: str) -> Subject | None:
    """The subject of a warning made by `about`, or None for a warning about the keyframe as a whole."""
    m = _PATTERN.match(text)
    if m is None:
        return None
    raw = m["name"]
    names, index = (), None
    if raw is not None and raw.startswith("'"):
        names = tuple(n[1:-1] for n in raw.split(" / "))
    elif raw is not None:
        index = int(raw)
    at = (float(m["x"]), float(m["y"])) if m["x"] is not None else None
    return Subject(m["kind"], names, index, at, m["problem"], m["fix"])


def inside_point(mask: np.ndarray) -> tuple[float, float] | None:
    """(x, y) pixels of the point of an (H, W) bool region farthest from its edge: where its warning is shown."""
    mask = np.asarray(mask, bool)
    if not mask.any():
        return None
    depth = ndimage.distance_transform_edt(np.pad(mask, 1))[1:-1, 1:-1]
    r, c = np.unravel_index(int(np.argmax(depth)), depth.shape)
    return float(c), float(r)
