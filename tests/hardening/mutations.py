"""Hypothesis strategies that mutate a shot directory: its shot.json (tree edits and raw text damage) and its images."""
from __future__ import annotations

import copy
import json
import re
from pathlib import Path

from hypothesis import strategies as st

from .shots import CORRUPTIONS, corrupt_image, with_image

SPECIAL_NUMBERS = [0, -1, 1, 2, 3, 0.5, 10**7, 10**400, -(10**400), 2**63, 1e308, -1e308, 1e-308, float("nan"),
                   float("inf"), float("-inf"), 1001, 129, 65]
SPECIAL_STRINGS = ["", ".", "..", "../key0.png", "/etc/passwd", "key0.png\x00", "shot.json", "key0_fg.png",
                   "a" * 2000, "~/x.png", "key1.png", "inbetween-shot/1", "subdir/", "\n"]
SIZES = [0, 1, 2, 3, 65, 129, 1001, 20000]

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(min_value=-(2**70), max_value=2**70) | st.sampled_from(SPECIAL_NUMBERS)
    | st.floats() | st.text(max_size=12) | st.sampled_from(SPECIAL_STRINGS),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=3),
    max_leaves=10,
)


def tree_paths(obj, prefix: tuple = ()) -> list[tuple]:
    """Every path into a JSON tree (the root is ())."""
    out = [prefix]
    if isinstance(obj, dict):
        for k, v in obj.items():
            out += tree_paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out += tree_paths(v, prefix + (i,))
    return out


def _get(obj, path: tuple):
    for p in path:
        obj = obj[p]
    return obj


def _set(obj, path: tuple, value):
    if not path:
        return value
    _get(obj, path[:-1])[path[-1]] = value
    return obj


@st.composite
def json_edit(draw, data: dict) -> dict:
    """One edit of the shot.json tree: a field first (so the many pose numbers do not crowd out the rest),
    then a node inside it: replaced, deleted, a list resized, a special number, or a number nudged."""
    field = draw(st.sampled_from(sorted(data))) if isinstance(data, dict) and data else None
    inside = tree_paths(data[field], (field,)) if field is not None else tree_paths(data)
    path = draw(st.sampled_from(inside))
    node = _get(data, path)
    action = draw(st.sampled_from(["replace", "delete", "resize", "number", "nudge", "nudge"]))
    if action == "delete" and path:
        parent = _get(data, path[:-1])
        del parent[path[-1]]
        return data
    if action == "resize" and isinstance(node, list) and node:
        n = draw(st.sampled_from(SIZES))
        return _set(data, path, (node * (n // len(node) + 1))[:n])
    if action == "number":
        return _set(data, path, draw(st.sampled_from(SPECIAL_NUMBERS)))
    if action == "nudge":  # mostly still valid: exercises what validation accepts
        numbers = [q for q in inside if isinstance(_get(data, q), (int, float)) and not isinstance(_get(data, q), bool)]
        if numbers:
            q = draw(st.sampled_from(numbers))
            try:
                return _set(data, q, _get(data, q) + draw(st.sampled_from([-3, -1, 1, 2, 0.25, -0.5])))
            except OverflowError:  # a 400-digit integer plus 0.25: leave it as it is
                return data
        return data
    return _set(data, path, draw(json_values))


@st.composite
def text_damage(draw, text: str) -> bytes:
    """Raw damage to shot.json's bytes: truncation, inserted junk, deep nesting, a BOM, invalid UTF-8."""
    raw = text.encode()
    kind = draw(st.sampled_from(["truncate", "insert", "nest", "bom", "latin1", "empty", "huge_int"]))
    at = draw(st.integers(0, len(raw)))
    if kind == "truncate":
        return raw[:at]
    if kind == "insert":
        return raw[:at] + draw(st.binary(min_size=1, max_size=8)) + raw[at:]
    if kind == "nest":
        depth = draw(st.sampled_from([50, 1000, 100_000]))
        return b"[" * depth + b"]" * depth
    if kind == "bom":
        return b"\xef\xbb\xbf" + raw
    if kind == "latin1":
        return raw.replace(b'"hips"', b'"h\xe9ps"')
    if kind == "empty":
        return b""
    return re.sub(rb'"frames": [0-9]+', b'"frames": ' + b"9" * 5000, raw)


@st.composite
def shot_mutation(draw, base: dict | None = None,
                  images: tuple[str, ...] = ("key0.png", "key1.png", "key0_fg.png", "key0_occ0.png"),
                  corruptions: tuple[str, ...] = CORRUPTIONS):
    """A function that mutates a written shot directory in place: 0 to 3 edits of its shot.json tree
    (`base`, default the small shot of shots.py), 0 to 2 image corruptions, sometimes raw text damage."""
    from .shots import shot_json

    data = copy.deepcopy(base) if base is not None else shot_json()
    for _ in range(draw(st.integers(0, 3))):
        data = draw(json_edit(data))
    image_edits = [(draw(st.sampled_from(images)), draw(st.sampled_from(corruptions)), draw(st.floats(0.01, 0.99)))
                   for _ in range(draw(st.integers(0, 2)))]
    damage = draw(st.one_of(st.none(), text_damage(json.dumps(data)))) if draw(st.integers(0, 4)) == 0 else None

    def apply(shot: Path) -> None:
        d = data
        for rel, kind, frac in image_edits:
            if (shot / rel).is_file():
                new = corrupt_image(shot, rel, kind, frac)
                if isinstance(d, dict):
                    d = with_image(d, rel, new)
        (shot / "shot.json").write_bytes(damage if damage is not None else json.dumps(d).encode())

    apply.description = f"shot.json={json.dumps(data)[:2000]} images={image_edits} damage={damage!r:.80}"
    return apply
