"""Geometry benchmark (§4.2-4.4): template build, topology optimization, 9-frame deformation per keyframe.

Synthetic 384 x 384 character: a torso capsule with a forearm capsule drawn in
front of it (one occlusion region per keyframe), the forearm swinging down
between the keyframes. Run: .venv/bin/python benchmarks/bench_geometry.py [--odd]
(--odd: one T-junction per region, i.e. the optuna cusp search).
Target: topology optimization + 9 deformed frames, both keyframes, <= 5 s.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ops.geometry.deform import Deformer, count_flipped, deform_sequence
from ops.geometry.template import build_template
from ops.geometry.topology import optimize_topology
from ops.types import RefinedMasks, Skeleton

S = 3.0  # 128-px layout scaled to 384 px
SKELETON = Skeleton(joints=("hips", "neck", "shoulder", "elbow", "hand"), parents=np.array([-1, 0, 1, 2, 3]))
POSE0 = np.array([[64, 100, 0], [64, 30, 0], [80, 40, -1], [78, 62, -1], [48, 66, -2]], float) * [S, S, 1]
POSE1 = POSE0.copy()
POSE1[4, :2] = np.array([70.0, 90.0]) * S


def capsule(a: np.ndarray, b: np.ndarray, rad: float, step: float) -> np.ndarray:
    """(n, 2) closed capsule polyline around segment a-b, pixels."""
    u = (b - a) / np.linalg.norm(b - a)
    ang0 = np.arctan2(u[1], u[0])
    n = max(int(np.pi * rad / step), 4)
    t1 = ang0 + np.linspace(-np.pi / 2, np.pi / 2, n + 1)
    t2 = ang0 + np.linspace(np.pi / 2, 3 * np.pi / 2, n + 1)
    return np.concatenate([b + rad * np.stack([np.cos(t1), np.sin(t1)], 1), a + rad * np.stack([np.cos(t2), np.sin(t2)], 1)])


def refined_masks(pose: np.ndarray, junctions: tuple[int, ...]) -> RefinedMasks:
    """RefinedMasks of the synthetic character at a (J, 3) pose: torso foreground, forearm occlusion region."""
    outer = capsule(pose[0, :2], pose[1, :2], 26 * S, 4 * S)
    occ = capsule(pose[3, :2], pose[4, :2], 6 * S, 2 * S)
    fg = np.zeros((384, 384), np.uint8)
    om = np.zeros((384, 384), np.uint8)
    cv2.fillPoly(fg, [np.round(outer).astype(np.int32)], 1)
    cv2.fillPoly(om, [np.round(occ).astype(np.int32)], 1)
    return RefinedMasks(
        foreground=fg.astype(bool), occlusion=[om.astype(bool)], front_bones=[np.array([3])],
        boundaries=[occ], junctions=[np.array(junctions, np.int64)], domain=[outer], domain_holes=np.zeros((0, 2)),
        coverage=fg.astype(np.float32), paper=np.ones(fg.shape + (3,), np.float32), colour=np.ones(fg.shape + (3,), np.float32),
    )


def run(odd: bool) -> float:
    """Benchmark both keyframes; print one line per stage and return the timed total (s)."""
    junctions = (5,) if odd else (3, 12)
    poses = POSE0[None] + np.linspace(0, 1, 9)[:, None, None] * (POSE1 - POSE0)[None]
    total = 0.0
    for key, (me, other, order) in enumerate([(POSE0, POSE1, "forward"), (POSE1, POSE0, "backward")]):
        refined = refined_masks(me, junctions)
        t0 = time.perf_counter()
        base = build_template(refined, me, SKELETON)
        t1 = time.perf_counter()
        tpl = optimize_topology(refined, me, other, SKELETON, seed=0)
        t2 = time.perf_counter()
        d = Deformer(tpl.rest, tpl.faces, tpl.handles)
        X, E, it = deform_sequence(tpl, poses, order, deformer=d)
        t3 = time.perf_counter()
        flips = max(count_flipped(x, tpl.faces) for x in X)
        print(
            f"key{key}: build {t1 - t0:.3f}s (V={len(base.V)} F={len(base.F)})  topology {t2 - t1:.3f}s "
            f"(V={len(tpl.rest)} F={len(tpl.faces)} regions={base.n_regions} T-junctions={len(junctions)} "
            f"trials={tpl.trials} cut={[c.tolist() for c in tpl.cut_assignment]} energy={tpl.energy:.4f})  "
            f"deform 9 frames {t3 - t2:.3f}s (iterations {it.tolist()}, max flipped {flips})"
        )
        total += t3 - t1
    print(f"topology optimization + 9 frames, both keyframes: {total:.3f} s (target <= 5 s)")
    return total


def main() -> None:
    """Parse flags and run."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--odd", action="store_true", help="one T-junction per region (cusp search with optuna)")
    run(ap.parse_args().odd)


if __name__ == "__main__":
    main()
