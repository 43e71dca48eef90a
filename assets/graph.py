"""The asset graph as data: every stage of a shot with its parents, for a shot of any number of keys.

Per keyframe k, a lane that both segments beside it share, computed once:
    key{k}/masks -> key{k}/refined_masks -> key{k}/template
(the template's cut topology is chosen against both neighbouring key poses, so the key deforms the same way
on both sides). Per segment s, between keys a = s and b = s + 1, each key's side of it, then the blending:
    seg{s}/key{a}/textured_template -> seg{s}/key{a}/deformed_frames  (and the same for key b)
    seg{s}/rife_matrix -> seg{s}/quality_metrics -> seg{s}/optimal_path -> seg{s}/frames
and the shot's `inbetween_frames` joins the segments' frames. A side's texture reads the segment's other
key (its drawing and refined masks show the pockets), and so do its deformed frames (registered onto the other
key's drawing, its masks' colour and coverage, as they near that key: ops/geometry/register.py), which is why
a side belongs to the segment: editing key k's annotation reruns key k's lane and the two segments beside it,
and nothing of the keys farther away.

A one-drawing shot (N = 1) has one segment, the whole motion, with one side and no blending:
    seg0/key0/textured_template -> seg0/key0/deformed_frames -> inbetween_frames

Sources (observable in Dagster, content-hashed by ops/shotio/versions.py): key{k}/drawing, key{k}/pose,
key{k}/t_junctions, seg{s}/motion (the poses of the segment's frames: a pose edited inside segment 1 leaves
segment 0 fresh) and ground_truth.

Two deliberate narrowings, so edits recompute less: the template reads the neighbouring key poses instead of
the motion (only they are its targets, §4.4), and it reads the T-junctions through the refined masks, which
carry them snapped onto the boundaries. A one-drawing shot's lane reads its motion instead: there is no other
key, so the poses it must reach are the motion's.
"""
from __future__ import annotations

import heapq
from dataclasses import dataclass
from functools import cache

from ops.shotio.load import MAX_KEYS

LANE_KINDS = ("masks", "refined_masks", "template")
SIDE_KINDS = ("textured_template", "deformed_frames")
BLEND_KINDS = ("rife_matrix", "quality_metrics", "optimal_path", "frames")
EVAL_STAGES = ("evaluation/rife_direct", "evaluation/single_layer", "evaluation/metrics")


def kind(stage: str) -> str:
    """What a stage computes, whatever key or segment it belongs to: 'seg1/key2/deformed_frames' ->
    'deformed_frames'."""
    return stage.rsplit("/", 1)[-1]


def side(s: int, k: int, name: str) -> str:
    """Stage name of key k's side of segment s: side(0, 1, "deformed_frames") = 'seg0/key1/deformed_frames'."""
    return f"seg{s}/key{k}/{name}"


@dataclass(frozen=True, eq=False)
class ShotGraph:
    """The stages of a shot with N keys and their parents (stages and sources), in an order parents-first."""

    n_keys: int
    parents: dict[str, tuple[str, ...]]  # every stage (the evaluation group's too) -> its parents
    sources: tuple[str, ...]
    all_stages: tuple[str, ...]  # every stage, parents first

    @property
    def n_segments(self) -> int:
        return max(1, self.n_keys - 1)

    @property
    def stages(self) -> tuple[str, ...]:
        """The shot's stages (the evaluation group left out), parents first."""
        return tuple(n for n in self.all_stages if n not in EVAL_STAGES)

    @property
    def eval_stages(self) -> tuple[str, ...]:
        return EVAL_STAGES

    def segment_keys(self, s: int) -> tuple[int, ...]:
        """The keys of segment s: (s, s + 1), or (0,) for a one-drawing shot."""
        return segment_keys(s, self.n_keys)


def _segment_neighbours(k: int, n: int) -> tuple[str, ...]:
    """What key k's lane reads of the keys beside it: their poses (N >= 2), or the motion (N = 1)."""
    if n == 1:
        return ("seg0/motion",)
    return tuple(f"key{j}/pose" for j in (k - 1, k + 1) if 0 <= j < n)


@cache
def shot_graph(n_keys: int) -> ShotGraph:
    """The graph of a shot with n_keys keyframes (1 <= n_keys <= MAX_KEYS)."""
    if not 1 <= n_keys <= MAX_KEYS:
        raise ValueError(f"a shot has 1 to {MAX_KEYS} keys, not {n_keys}")
    n_seg = max(1, n_keys - 1)
    sources = tuple(f"key{k}/{f}" for k in range(n_keys) for f in ("drawing", "pose", "t_junctions"))
    sources += tuple(f"seg{s}/motion" for s in range(n_seg)) + ("ground_truth",)
    parents: dict[str, tuple[str, ...]] = {}
    for k in range(n_keys):
        around = _segment_neighbours(k, n_keys)
        parents[f"key{k}/masks"] = (f"key{k}/drawing", f"key{k}/pose")
        parents[f"key{k}/refined_masks"] = (f"key{k}/masks", f"key{k}/t_junctions", f"key{k}/pose", *around)
        parents[f"key{k}/template"] = (f"key{k}/refined_masks", f"key{k}/pose", *around)
    if n_keys == 1:
        parents[side(0, 0, "textured_template")] = ("key0/template", "key0/refined_masks", "key0/pose")
        parents[side(0, 0, "deformed_frames")] = (side(0, 0, "textured_template"), "seg0/motion")
        parents["inbetween_frames"] = (side(0, 0, "deformed_frames"),)
    for s in range(n_keys - 1):
        a, b = s, s + 1
        for k, o in ((a, b), (b, a)):
            parents[side(s, k, "textured_template")] = (f"key{k}/template", f"key{k}/refined_masks",
                                                        f"key{o}/refined_masks", f"key{k}/pose", f"key{o}/pose")
            parents[side(s, k, "deformed_frames")] = (side(s, k, "textured_template"), f"seg{s}/motion",
                                                      f"key{o}/masks")
        lanes = (side(s, a, "deformed_frames"), side(s, b, "deformed_frames"))
        parents[f"seg{s}/rife_matrix"] = lanes
        parents[f"seg{s}/quality_metrics"] = (f"seg{s}/rife_matrix", *lanes)
        parents[f"seg{s}/optimal_path"] = (f"seg{s}/quality_metrics",)
        parents[f"seg{s}/frames"] = (f"seg{s}/rife_matrix", f"seg{s}/optimal_path", *lanes)
    if n_keys > 1:
        parents["inbetween_frames"] = tuple(f"seg{s}/frames" for s in range(n_seg))
    drawings = tuple(f"key{k}/drawing" for k in range(n_keys))
    motions = tuple(f"seg{s}/motion" for s in range(n_seg))
    sides = tuple(side(s, k, "deformed_frames") for s in range(n_seg) for k in segment_keys(s, n_keys))
    blends = tuple(f"seg{s}/{x}" for s in range(n_keys - 1) for x in ("rife_matrix", "optimal_path"))
    parents["evaluation/rife_direct"] = (*drawings, *motions)
    parents["evaluation/single_layer"] = (*(f"key{k}/refined_masks" for k in range(n_keys)),
                                          *(f"key{k}/pose" for k in range(n_keys)), *motions)
    parents["evaluation/metrics"] = ("inbetween_frames", *blends, "evaluation/single_layer", "evaluation/rife_direct",
                                     *sides, *(f"key{k}/masks" for k in range(n_keys)), *drawings, "ground_truth")
    return ShotGraph(n_keys, parents, sources, topological(parents))


def segment_keys(s: int, n_keys: int) -> tuple[int, ...]:
    """The keys of segment s of a shot with n_keys keys: (s, s + 1), or (0,) for one drawing."""
    return (0,) if n_keys == 1 else (s, s + 1)


def topological(parents: dict[str, tuple[str, ...]]) -> tuple[str, ...]:
    """Stages ordered so that each comes after all of its parents (ties keep the table's order): Kahn's
    algorithm taking the earliest ready stage in the table each time, O(E + V log V)."""
    order = {n: i for i, n in enumerate(parents)}
    waiting = {n: sum(p in parents for p in set(ps)) for n, ps in parents.items()}
    children: dict[str, list[str]] = {n: [] for n in parents}
    for n, ps in parents.items():
        for p in set(ps):
            if p in parents:
                children[p].append(n)
    ready = [order[n] for n, w in waiting.items() if w == 0]
    heapq.heapify(ready)
    names = list(parents)
    done: list[str] = []
    while ready:
        n = names[heapq.heappop(ready)]
        done.append(n)
        for c in children[n]:
            waiting[c] -= 1
            if waiting[c] == 0:
                heapq.heappush(ready, order[c])
    if len(done) < len(parents):
        raise ValueError(f"the stage graph has a cycle among {sorted(set(parents) - set(done))}")
    return tuple(done)


@cache
def union_graph() -> dict[str, tuple[str, ...]]:
    """Every stage any shot can have (up to MAX_KEYS keys), with the union of its parents over shot sizes: the
    Dagster Definitions' assets and their lineage."""
    out: dict[str, list[str]] = {}
    for n in range(1, MAX_KEYS + 1):
        for name, ps in shot_graph(n).parents.items():
            have = out.setdefault(name, [])
            have.extend(p for p in ps if p not in have)
    return {n: tuple(ps) for n, ps in out.items()}


@cache
def union_sources() -> tuple[str, ...]:
    seen: dict[str, None] = {}
    for n in range(1, MAX_KEYS + 1):
        seen.update(dict.fromkeys(shot_graph(n).sources))
    return tuple(seen)
