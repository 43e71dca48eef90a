"""Nested occlusion regions where two front bones of one region cross each other (three local layers, §4.2).

A predicted region holds every pixel where something is hidden, its front bones the parts in front there. Where
both forearms fold over the chest, one region has both forearms as front bones, and meshed as one pocket the two
forearms share the front sheet and stay glued where they cross. The drawing has three layers there: the top
forearm, the lower one, the chest. So the region is split in two that overlap at the crossing:
- the lower forearm's: where its body lies in the region (over the chest, and under the top forearm), front bone
  the lower forearm;
- the rest's: the region less where only the lower forearm is in front, front bones the others.
The template stacks them by their front bones' depth (ops.geometry.template) and meshes the crossing three times.
"""
from __future__ import annotations

import re

import numpy as np

from ops.segmentation.bones import bone_depths, thick_regions
from ops.segmentation.contacts import scale_of
from ops.segmentation.occlusion_pairs import bone_name
from ops.types import Skeleton

MIN_CROSSING_PX = 40  # at the reference size: two front bones' bodies meeting on less inside a region only touch


def nest_crossed_fronts(regions: list[np.ndarray], fronts: list[np.ndarray], body: np.ndarray, pose: np.ndarray,
                        skeleton: Skeleton) -> tuple[list[np.ndarray], list[np.ndarray], list[int], list[str]]:
    """Regions ((H, W) bool each) with their (b,) int64 front bones -> the same with each region whose front bones
    cross in it (two bones not sharing a joint, at different depths, whose bodies meet on MIN_CROSSING_PX there)
    split into the lower bone's region and the rest's, which overlap at the crossing; per region its nest group
    (the regions of one group >= 0 are layers of one stack, Masks.nest_groups; -1: none); one note per split.
    body: (H, W) bool the drawn bodies; pose (J, 3) pixels and depth."""
    if not any(len(f) >= 2 for f in fronts):
        return list(regions), list(fronts), [-1] * len(regions), []
    thick = thick_regions(body, pose, skeleton)
    depth = bone_depths(pose, skeleton)
    adjacent = skeleton.adjacent_bones()
    limbs = _limbs(skeleton)
    apart = ~(limbs[:, None] & limbs[None, :] & _twins(skeleton))  # pairs that cannot cross: twin limbs only
    min_px = MIN_CROSSING_PX * scale_of(body) ** 2
    out_r, out_f, out_g, notes = [], [], [], []
    queue = [(r, f, -1) for r, f in zip(regions, fronts)]
    groups = 0
    while queue:
        region, front, group = queue.pop(0)
        crossing = _crossing(region, front, thick, depth, adjacent, apart, min_px)
        if crossing is None:
            out_r.append(region)
            out_f.append(front)
            out_g.append(group)
            continue
        if group < 0:
            group, groups = groups, groups + 1
        top, low = crossing
        lower = region & thick[low]
        rest = region & ~(thick[low] & ~thick[top])
        rest_front = np.asarray([b for b in front if b != low], np.int64)
        out_r.append(lower)
        out_f.append(np.asarray([low], np.int64))
        out_g.append(group)
        queue.insert(0, (rest, rest_front, group))  # the rest may hold another crossing (three forearms: a puppet's)
        top_name, low_name = bone_name(skeleton, top), bone_name(skeleton, low)
        notes.append(f"occlusion: bones {top_name} and {low_name} cross in front of the body on "
                     f"{int((lower & thick[top]).sum())} px: three local layers there ({top_name} over {low_name} "
                     "over what they cover)")
    return out_r, out_f, out_g, notes


def _crossing(region: np.ndarray, front: np.ndarray, thick: np.ndarray, depth: np.ndarray, adjacent: np.ndarray,
              apart: np.ndarray, min_px: float) -> tuple[int, int] | None:
    """(top, low) bones of the largest crossing of two of a region's front bones in it, or None.

    A crossing is where twin limbs of two branches of the skeleton (the two forearms) both lie over a third
    body, farther than both and joined to neither (the chest under two forearms). apart: (B, B) bool pairs
    that cannot cross: one of them no limb (a spine or a hip bone, below which the skeleton forks: a near thigh
    over the torso's bone in a side view is the thigh over the body, one overlap), or no twins (a thigh and its
    own foot are one limb; an arm hanging over the near thigh: nested, r03-r05 of the held-out redrawn set lost
    0.3-1.4 dB, the folded arms gained 0.03-0.3). As for the occlusion rule's
    pairs, bones joined through one short bone (spine - clavicle - upper arm) meet around it, and that bone's
    body is no crossing."""
    best, where = None, 0
    front = [int(b) for b in front]
    for i, a in enumerate(front):
        for b in front[i + 1:]:
            if adjacent[a, b] or apart[a, b] or np.isclose(depth[a], depth[b]):
                continue
            between = adjacent[a] & adjacent[b]
            beneath = (depth > max(depth[a], depth[b])) & ~adjacent[a] & ~adjacent[b]
            if not beneath.any():
                continue
            crossing = region & thick[a] & thick[b] & thick[beneath].any(axis=0)
            if between.any():
                crossing &= ~thick[between].any(axis=0)
            n = int(crossing.sum())
            if n >= min_px and n > where:
                best, where = ((a, b) if depth[a] < depth[b] else (b, a)), n
    return best


def _limbs(skeleton: Skeleton) -> np.ndarray:
    """(B,) bool: bones whose child joint's subtree never branches (a forearm, a shin, a tail's segment), not a
    spine or a hip bone, below which the skeleton forks."""
    parents = np.asarray(skeleton.parents)
    children = np.bincount(parents[parents >= 0], minlength=len(parents))
    forks_below = children > 1
    for j in range(len(parents) - 1, -1, -1):  # joints come after their parents: children first, fold upwards
        if parents[j] >= 0 and forks_below[j]:
            forks_below[parents[j]] = True
    return np.array([not forks_below[int(c)] for _, c in np.asarray(skeleton.bones)], bool)


_SIDE = re.compile(r"(?<![a-z])(left|right|l|r)(?![a-z])|left|right")  # a side token in a lower-cased name


def _twins(skeleton: Skeleton) -> np.ndarray:
    """(B, B) bool: bone pairs that are the same limb of two sides: as far below the joint where their branches
    part (the two forearms, not an upper arm and a thigh), and named alike but for the side (l_hand, r_hand;
    left_elbow, right_elbow), or where no joint names a side, with as many joints below them. A thigh and a
    tail's segment can sit as far below the root and hold as many joints: their names tell them apart."""
    names = [n.lower() for n in skeleton.joints]
    sided = any(_SIDE.search(n) for n in names)
    parents = np.asarray(skeleton.parents)
    below = np.ones(len(parents), np.int64)
    for j in range(len(parents) - 1, 0, -1):  # joints come after their parents
        if parents[j] >= 0:
            below[parents[j]] += below[j]
    child = [int(c) for _, c in np.asarray(skeleton.bones)]
    if sided:
        stem = [_SIDE.sub("#", names[c]) for c in child]
        alike = np.array([[stem[a] == stem[b] and names[child[a]] != names[child[b]] for b in range(len(child))]
                          for a in range(len(child))], bool)
    else:
        alike = below[child][:, None] == below[child][None, :]
    return _mirrored(skeleton) & alike


def _mirrored(skeleton: Skeleton) -> np.ndarray:
    """(B, B) bool: bone pairs as far below the joint where their branches part (the two forearms, the two
    shins), not an upper arm and a thigh, nor two bones of one limb (the upper one's child joint is where they
    part: none of its steps against the lower one's)."""
    parents = np.asarray(skeleton.parents)

    def path(j: int) -> list[int]:  # the joint and its ancestors, root last
        out = [j]
        while parents[out[-1]] >= 0:
            out.append(int(parents[out[-1]]))
        return out

    paths = [path(int(c)) for _, c in np.asarray(skeleton.bones)]
    B = len(paths)
    out = np.zeros((B, B), bool)
    for a in range(B):
        for b in range(B):
            common = set(paths[b])
            below_a = next(i for i, j in enumerate(paths[a]) if j in common)  # steps up to the parting joint
            below_b = paths[b].index(paths[a][below_a])
            out[a, b] = below_a == below_b
    return out
