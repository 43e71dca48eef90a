"""AnimatedDrawings' files: a character folder (char_cfg.yaml, texture.png, mask.png) and retarget configs.

Their YAML tags tuples `!!python/tuple`; a yaml.SafeLoader subclass reads that one tag as a tuple and nothing
else of Python's (yaml's unsafe loaders are never used). The fields follow AnimatedDrawings' own docs
(examples/config/README.md): char_cfg `skeleton: [{name, parent, loc: [x, y]}]` in texture pixels, `width`,
`height`; a retarget config's `bvh_projection_bodypart_groups`, `char_bodypart_groups`, `char_bvh_root_offset`
and `char_joint_bvh_joints_mapping`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import yaml

from ops.errors import ShotError

PROJECTIONS = ("frontal", "sagittal", "pca")
SPELLINGS = {"saggital": "sagittal"}  # AnimatedDrawings' own code spells it so
MAX_YAML_BYTES = 4 * 2**20


class TupleSafeLoader(yaml.SafeLoader):
    """yaml's SafeLoader plus exactly one Python tag, `!!python/tuple`, read as a tuple."""


TupleSafeLoader.add_constructor(
    "tag:yaml.org,2002:python/tuple", lambda loader, node: tuple(loader.construct_sequence(node)))


def read_yaml(path: str | Path, what: str) -> dict:
    """The top-level mapping of a YAML file; ShotError on a missing, unreadable or non-mapping file."""
    file = Path(path)
    if not file.is_file():
        raise ShotError(file, what, "file not found", f"give the path of AnimatedDrawings' {what}")
    if file.stat().st_size > MAX_YAML_BYTES:
        raise ShotError(file, what, "file is larger than 4 MB", f"give AnimatedDrawings' {what} (a few kB)")
    try:
        loader = TupleSafeLoader(file.read_text(encoding="utf-8"))  # what yaml.load does, with our SafeLoader
        try:
            data = loader.get_single_data()
        finally:
            loader.dispose()
    except (yaml.YAMLError, UnicodeDecodeError) as e:
        line = getattr(getattr(e, "problem_mark", None), "line", None)
        where = f" at line {line + 1}" if line is not None else ""
        raise ShotError(file, what, f"is not valid YAML{where} ({type(e).__name__})",
                        "fix the YAML syntax (only the tag !!python/tuple is allowed)") from None
    if not isinstance(data, dict):
        raise ShotError(file, what, "top level is not a mapping", f"give AnimatedDrawings' {what}")
    return data


@dataclass(frozen=True)
class Character:
    """An AnimatedDrawings character: its drawing, mask and skeleton in texture pixels."""

    texture: Path
    mask: Path | None
    size: tuple[int, int]  # (H, W) pixels
    joints: tuple[str, ...]
    parents: tuple[int, ...]  # -1 for the root
    pose: np.ndarray  # (J, 2) float64 x, y pixels (y down, as in the texture)


def read_character(char_cfg: str | Path) -> Character:
    """Read char_cfg.yaml and find texture.png and mask.png beside it."""
    file = Path(char_cfg)
    data = read_yaml(file, "char_cfg.yaml")
    rows = data.get("skeleton")
    if not isinstance(rows, list) or not rows:
        raise ShotError(file, "skeleton", "missing or not a list", "list the joints as {name, parent, loc: [x, y]}")
    names: list[str] = []
    for i, r in enumerate(rows):
        if not isinstance(r, dict) or not isinstance(r.get("name"), str):
            raise ShotError(file, f"skeleton[{i}]", "needs a name", "give every joint {name, parent, loc}")
        names.append(r["name"])
    if len(set(names)) != len(names):
        raise ShotError(file, "skeleton", "joint names repeat", "give every joint a unique name")
    parents, pose = [], []
    for i, r in enumerate(rows):
        par = r.get("parent")
        if par is not None and par not in names:
            raise ShotError(file, f"skeleton[{i}].parent", f"{par!r} is not a joint", "name an existing joint or null")
        parents.append(-1 if par is None else names.index(par))
        loc = r.get("loc")
        if (not isinstance(loc, (list, tuple)) or len(loc) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in loc)):
            raise ShotError(file, f"skeleton[{i}].loc", f"{loc!r} is not [x, y]", "give the joint's pixel position [x, y]")
        pose.append([float(loc[0]), float(loc[1])])
    if parents.count(-1) != 1:
        raise ShotError(file, "skeleton", f"{parents.count(-1)} joints without a parent", "give exactly one root (parent: null)")
    for i in range(len(names)):
        j, steps = i, 0
        while j != -1:
            j, steps = parents[j], steps + 1
            if steps > len(names):
                raise ShotError(file, "skeleton", f"cycle through {names[i]!r}", "make the parents form a tree")
    w, h = data.get("width"), data.get("height")
    if not all(isinstance(v, int) and v > 0 for v in (w, h)):
        raise ShotError(file, "width/height", "missing or not positive integers", "give the texture's width and height")
    texture = file.parent / "texture.png"
    if not texture.is_file():
        raise ShotError(texture, "texture.png", "not found beside char_cfg.yaml", "put the character's drawing there")
    mask = file.parent / "mask.png"
    return Character(texture, mask if mask.is_file() else None, (h, w), tuple(names), tuple(parents),
                     np.asarray(pose, np.float64))


@dataclass(frozen=True)
class ProjectionGroup:
    """BVH joints projected onto one plane: frontal (seen from the front), sagittal (from the side) or pca."""

    name: str
    method: str
    bvh_joints: tuple[str, ...]


@dataclass(frozen=True)
class DepthGroup:
    """Character joints whose depth follows the mean depth of some BVH joints (the render order's drivers)."""

    drivers: tuple[str, ...]
    char_joints: tuple[str, ...]


@dataclass(frozen=True)
class RetargetConfig:
    """AnimatedDrawings' retarget config: how a BVH skeleton drives a character's 2D rig."""

    file: Path
    projection_groups: tuple[ProjectionGroup, ...]
    depth_groups: tuple[DepthGroup, ...]
    root_group: str  # projection group whose plane moves the root
    root_bvh_chains: tuple[tuple[str, ...], ...]  # leg chains whose lengths give the character-to-BVH scale
    root_char_chains: tuple[tuple[str, ...], ...]
    mapping: dict[str, tuple[str, str]]  # character joint -> (BVH proximal, BVH distal): its bone's direction
    checks: tuple[tuple[str, str, str, str], ...] = ()  # char_runtime_checks: ('above', target, joint1, joint2)

    def bvh_joints(self) -> list[tuple[str, str]]:
        """(field, BVH joint name) of every BVH joint the config names."""
        out = [(f"bvh_projection_bodypart_groups.{g.name}", j) for g in self.projection_groups for j in g.bvh_joints]
        out += [("char_bodypart_groups.bvh_depth_drivers", j) for g in self.depth_groups for j in g.drivers]
        out += [("char_bvh_root_offset.bvh_joints", j) for c in self.root_bvh_chains for j in c]
        out += [(f"char_joint_bvh_joints_mapping.{c}", j) for c, pd in self.mapping.items() for j in pd]
        return out

    def char_joints(self) -> list[tuple[str, str]]:
        """(field, character joint name) of every character joint the config names."""
        out = [("char_bodypart_groups.char_joints", j) for g in self.depth_groups for j in g.char_joints]
        out += [("char_bvh_root_offset.char_joints", j) for c in self.root_char_chains for j in c]
        out += [("char_joint_bvh_joints_mapping", c) for c in self.mapping]
        out += [(f"char_runtime_checks[{i}]", j) for i, c in enumerate(self.checks) for j in c[1:]]
        return out


def numbered_copies(config: RetargetConfig, joints: tuple[str, ...]) -> tuple[RetargetConfig, list[str]]:
    """The config with each character joint it names that the skeleton lacks, but whose numbered copies
    (`right_shoulder1`, `right_shoulder2`, ...: the name and digits) the skeleton has, replaced by those copies:
    every copy is mapped, grouped and checked as the joint is (so three right arms move as one, the way
    AnimatedDrawings' own six-armed config drives them). The leg chains that scale the clip take the first copy
    only: they measure one leg. -> (config, one line per joint replaced, to say so)."""
    copies = {}
    for _, name in config.char_joints():
        if name not in joints and name not in copies:
            found = sorted((j for j in joints if j.startswith(name) and j[len(name):].isdigit()),
                           key=lambda j: int(j[len(name):]))
            if found:
                copies[name] = tuple(found)
    if not copies:
        return config, []

    def each(names):
        return tuple(c for n in names for c in copies.get(n, (n,)))

    def first(names):
        return tuple(copies[n][0] if n in copies else n for n in names)

    checks = tuple((above, t, *first((j1, j2))) for above, target, j1, j2 in config.checks for t in each((target,)))
    mapping = {c: bones for n, bones in config.mapping.items() for c in each((n,))}
    numbered = replace(config, depth_groups=tuple(replace(g, char_joints=each(g.char_joints)) for g in config.depth_groups),
                       root_char_chains=tuple(first(c) for c in config.root_char_chains), mapping=mapping,
                       checks=checks)
    return numbered, [f"{Path(config.file).name}: {n} drives its numbered copies {', '.join(c)}"
                      for n, c in copies.items()]


def _names(value, file: Path, field: str) -> tuple[str, ...]:
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        raise ShotError(file, field, "is not a list of joint names", "list the joint names")
    return tuple(value)


def read_retarget(path: str | Path) -> RetargetConfig:
    """Read and check an AnimatedDrawings retarget config (e.g. fair1_ppf.yaml, cmu1_pfp.yaml)."""
    file = Path(path)
    data = read_yaml(file, "retarget config")
    groups = []
    raw = data.get("bvh_projection_bodypart_groups")
    if not isinstance(raw, list) or not raw:
        raise ShotError(file, "bvh_projection_bodypart_groups", "missing or empty",
                        "list groups of {name, method: pca|frontal|sagittal, bvh_joint_names}")
    for i, g in enumerate(raw):
        field = f"bvh_projection_bodypart_groups[{i}]"
        if not isinstance(g, dict):
            raise ShotError(file, field, "is not a mapping", "give {name, method, bvh_joint_names}")
        method = SPELLINGS.get(g.get("method"), g.get("method"))
        if method not in PROJECTIONS:
            raise ShotError(file, f"{field}.method", f"{g.get('method')!r} is not a projection",
                            f"use one of {', '.join(PROJECTIONS)}")
        groups.append(ProjectionGroup(str(g.get("name", f"group{i}")), method,
                                      _names(g.get("bvh_joint_names"), file, f"{field}.bvh_joint_names")))
    depth = []
    for i, g in enumerate(data.get("char_bodypart_groups") or []):
        field = f"char_bodypart_groups[{i}]"
        if not isinstance(g, dict):
            raise ShotError(file, field, "is not a mapping", "give {bvh_depth_drivers, char_joints}")
        depth.append(DepthGroup(_names(g.get("bvh_depth_drivers"), file, f"{field}.bvh_depth_drivers"),
                                _names(g.get("char_joints"), file, f"{field}.char_joints")))
    root = data.get("char_bvh_root_offset")
    if not isinstance(root, dict):
        raise ShotError(file, "char_bvh_root_offset", "missing or not a mapping",
                        "give bvh_projection_bodypart_group_for_offset, bvh_joints and char_joints")
    root_group = root.get("bvh_projection_bodypart_group_for_offset")
    if root_group not in [g.name for g in groups]:
        raise ShotError(file, "char_bvh_root_offset.bvh_projection_bodypart_group_for_offset",
                        f"{root_group!r} is not a projection group", "name one of bvh_projection_bodypart_groups")
    chains = {}
    for key in ("bvh_joints", "char_joints"):
        val = root.get(key)
        if not isinstance(val, (list, tuple)) or not val:
            raise ShotError(file, f"char_bvh_root_offset.{key}", "missing or empty", "list chains of joint names")
        chains[key] = tuple(_names(c, file, f"char_bvh_root_offset.{key}") for c in val)
    mapping_raw = data.get("char_joint_bvh_joints_mapping")
    if not isinstance(mapping_raw, dict) or not mapping_raw:
        raise ShotError(file, "char_joint_bvh_joints_mapping", "missing or empty",
                        "map character joints to (BVH proximal, BVH distal) joint pairs")
    mapping = {}
    for c, pd in mapping_raw.items():
        names = _names(pd, file, f"char_joint_bvh_joints_mapping.{c}")
        if len(names) != 2:
            raise ShotError(file, f"char_joint_bvh_joints_mapping.{c}", f"has {len(names)} names",
                            "give exactly two: the BVH bone's proximal and distal joint")
        mapping[str(c)] = (names[0], names[1])
    checks = []
    for i, c in enumerate(data.get("char_runtime_checks") or []):
        if not (isinstance(c, (list, tuple)) and len(c) == 4 and all(isinstance(v, str) for v in c) and c[0] == "above"):
            raise ShotError(file, f"char_runtime_checks[{i}]", f"{c!r} is not [above, target, joint1, joint2]",
                            "write the check as AnimatedDrawings does, or leave it out")
        checks.append(tuple(c))
    return RetargetConfig(file, tuple(groups), tuple(depth), root_group, chains["bvh_joints"], chains["char_joints"],
                          mapping, tuple(checks))
