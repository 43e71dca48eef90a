"""Geometry benchmark (§4.2-4.4): the cut search, the texture solve and the 9-frame deformation, per solver.

Problems: a synthetic 384 x 384 character (a torso capsule with a forearm capsule drawn in front of it, one
occlusion region per keyframe, the forearm swinging down between the keyframes; --odd gives its region one
T-junction, the cusp search), or with --shots DIR every keyframe of the sample shots there (their refined
masks computed first, not timed; with --odd one more T-junction on every region with an even count, in the
middle of its longest stretch without one, so that every region's cut is searched by its cusp: the test bed
for a change to that search). Per keyframe and per solver, on the same problems:
- search: optimize_topology (the template's cut search, scored along the motion), its CPU seconds, the
  deformation iterations it took, the topologies it deformed and the winner's energy;
- texture: the textured template's solve to the other key pose (ops/appearance/lane.py texture_lane), from the
  search's solution there (Template.target_x) as the pipeline starts it;
- frames: the 9-frame deformation, each frame from its neighbour (deform_sequence), and its folds;
both on the mesh the Newton search chose. Solvers: `newton` (projected Newton, L-BFGS steps where the
injectivity bound blocks it: the cut search's) and `lbfgs` (the Laplacian-preconditioned L-BFGS: the lanes').
--slim adds libigl's SLIM (igl.slim_solve, symmetric Dirichlet, the handles as soft constraints) on the same
frames, from the same starts: its iterations, seconds and the energy it reaches, in our energy.

    python benchmarks/bench_geometry.py [--odd] [--shots data_samples [--only arm_cross ...]] [--slim]
                                        [--search-only]

Times are CPU seconds of this process (the machine is shared: wall times are noise).
Target: topology optimization + 9 frames, both keyframes of the synthetic character, <= 5 s.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ops.geometry import deform as deform_module  # noqa: E402
from ops.geometry.deform import SOLVERS, Deformer, count_flipped, deform_sequence  # noqa: E402
from ops.geometry.topology import Solver, optimize_topology  # noqa: E402
from ops.types import RefinedMasks, Skeleton, Template  # noqa: E402

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


def synthetic_problems(odd: bool) -> list[tuple]:
    """(name, refined masks, own key pose, other key pose, skeleton, poses (9, J, 3), key index) per keyframe."""
    junctions = (5,) if odd else (3, 12)
    poses = POSE0[None] + np.linspace(0, 1, 9)[:, None, None] * (POSE1 - POSE0)[None]
    return [(f"synthetic key{k}", refined_masks(me, junctions), me, other, SKELETON, poses, k)
            for k, (me, other) in enumerate([(POSE0, POSE1), (POSE1, POSE0)])]


def one_more_junction(refined: RefinedMasks) -> RefinedMasks:
    """`refined` with one more T-junction on every region whose count is even: mid-way along its longest stretch
    of boundary without one (at its first vertex where it has none), so that every region's count is odd."""
    junctions = []
    for boundary, jn in zip(refined.boundaries, refined.junctions):
        jn, n = np.unique(np.asarray(jn, np.int64)), len(boundary)
        if len(jn) == 0:
            jn = np.zeros(1, np.int64)
        elif len(jn) % 2 == 0:
            gaps = np.diff(np.r_[jn, jn[0] + n])
            g = int(np.argmax(gaps))
            jn = np.unique(np.r_[jn, (jn[g] + gaps[g] // 2) % n])
        junctions.append(jn)
    return replace(refined, junctions=junctions)


def shot_problems(root: Path, only: list[str] | None, odd: bool = False) -> list[tuple]:
    """The same for every keyframe of the shots under root: refined masks as the pipeline computes them (odd:
    one_more_junction's)."""
    from ops.segmentation.masks import build_masks
    from ops.segmentation.refine import refine_masks
    from ops.shotio.image_io import read_image, to_rgba
    from ops.shotio.load import load_shot

    def mask(path: str) -> np.ndarray:
        img = read_image(path)
        return img[..., 0] > 0.5 if img.shape[2] < 4 else (img[..., 0] > 0.5) & (img[..., 3] > 0.5)

    out = []
    for d in sorted(p for p in root.iterdir() if (p / "shot.json").is_file()):
        if only and d.name not in only:
            continue
        shot = load_shot(d)
        if shot.n_keys < 2:  # a one-drawing shot: no other key to deform towards
            continue
        for k in (0, 1):  # the first segment's two keys (a longer shot's other segments are alike)
            other = 1 - k
            fg = shot.foreground_masks[k]
            occ = [mask(p) for p in shot.occlusion_masks[k]] or None
            masks = build_masks(to_rgba(read_image(shot.keyframes[k])), shot.key_pose(k), shot.skeleton,
                                mask(fg) if fg else None, occ, source=shot.keyframes[k], occlusion="hybrid")
            refined = refine_masks(masks, shot.t_junctions[k], shot.key_pose(k), shot.skeleton, shot.key_pose(other))
            refined = one_more_junction(refined) if odd else refined
            out.append((f"{d.name} key{k}", refined, shot.key_pose(k), shot.key_pose(other), shot.skeleton,
                        shot.segment_poses(0), k))
        print(f"  {d.name}: masks ready", file=sys.stderr, flush=True)
    return out


class IterationCount:
    """Counts the iterations of every Deformer.solve while installed (the search's solves are inside it)."""

    def __init__(self):
        self.iterations = 0
        self._solve = Deformer.solve

    def __enter__(self):
        def counted(deformer, *args, **kwargs):
            res = self._solve(deformer, *args, **kwargs)
            self.iterations += res.iterations
            return res

        deform_module.Deformer.solve = counted
        return self

    def __exit__(self, *exc):
        deform_module.Deformer.solve = self._solve


def cpu_timed(fn):
    """(result, CPU seconds) of one call."""
    c = time.process_time()
    out = fn()
    return out, time.process_time() - c


def slim_frames(template: Template, poses: np.ndarray, backward: bool, starts: list[np.ndarray],
                energies: np.ndarray, max_iter: int = 50) -> tuple[int, float, float, int]:
    """libigl's SLIM on each frame from `starts` (the previous frame's solution, pixels) until our energy is within
    1e-4 of `energies` (the Newton solve's, per frame) or max_iter: (iterations, CPU s, worst energy, folds)."""
    import igl

    d = Deformer(template.rest, template.faces, template.handles)
    F = np.asfortranarray(template.faces.astype(np.int32))
    rest = np.asfortranarray(np.c_[d.rest_n, np.zeros(len(d.rest_n))])  # SLIM reads the rest mesh in 3D
    iterations, cpu, worst, folds = 0, 0.0, 0.0, 0
    order = range(len(poses) - 1, -1, -1) if backward else range(len(poses))
    for i, x0 in zip(order, starts):
        T = d.norm.to_norm(template.handle_targets(poses[i]))
        c = time.process_time()
        data = igl.slim_precompute(rest, F, np.asfortranarray(d.norm.to_norm(x0)),
                                   igl.MappingEnergyType.SYMMETRIC_DIRICHLET, template.handles.astype(np.int32),
                                   np.asfortranarray(T), d.mu)
        e, done = np.inf, 0
        while done < max_iter and not e <= energies[i] * (1 + 1e-4):
            X = np.ascontiguousarray(igl.slim_solve(data, 1)[:, :2])
            e, done = d.energy_fn.energy(X, T), done + 1
        cpu += time.process_time() - c
        iterations += done
        worst = max(worst, e)
        folds += count_flipped(X, template.faces)
    return iterations, cpu, worst, folds


def run(problems: list[tuple], slim: bool, search_only: bool = False) -> None:
    """Print one line per keyframe and solver, then the totals per solver (search_only: the Newton search, its
    chosen cuts, nothing else)."""
    if search_only:
        run_searches(problems)
        return
    totals = {m: np.zeros(6) for m in SOLVERS}
    print(f"{'problem':24s} {'solver':7s} | {'search s':>8s} {'it':>6s} {'topos':>5s} {'energy':>8s} | "
          f"{'texture s':>9s} {'it':>5s} {'energy':>8s} | {'9 frames s':>10s} {'it':>5s} {'E max':>8s} {'folds':>5s}")
    for name, refined, me, other, skeleton, poses, k in problems:
        chosen = None
        for method in SOLVERS:
            with IterationCount() as count:
                tpl, search_s = cpu_timed(lambda: optimize_topology(refined, me, other, skeleton,
                                                                    solver=Solver(method=method)))
            chosen = chosen or tpl  # the Newton search's template: the mesh both solvers deform below
            d = Deformer(chosen.rest, chosen.faces, chosen.handles, method=method)
            start = chosen.target_x[0] if chosen.target_x and len(chosen.target_x[0]) else None
            tex, tex_s = cpu_timed(lambda: d.solve(chosen.handle_targets(other), x0=start))
            (X, E, it), seq_s = cpu_timed(lambda: deform_sequence(chosen, poses, "backward" if k else "forward", d))
            folds = sum(count_flipped(x, chosen.faces) for x in X)
            print(f"{name:24s} {method:7s} | {search_s:8.2f} {count.iterations:6d} {tpl.trials:5d} {tpl.energy:8.4f} | "
                  f"{tex_s:9.2f} {tex.iterations:5d} {tex.energy:8.4f} | {seq_s:10.2f} {int(it.sum()):5d} "
                  f"{E.max():8.4f} {folds:5d}", flush=True)
            totals[method] += [search_s, count.iterations, tex_s, tex.iterations, seq_s, it.sum()]
            if method == SOLVERS[0]:
                newton_X, newton_E = X, E
        if slim:
            order = list(range(len(poses) - 1, -1, -1) if k else range(len(poses)))
            starts = [chosen.rest] + [newton_X[i] for i in order[:-1]]
            it, cpu, worst, folds = slim_frames(chosen, poses, k == 1, starts, newton_E)
            print(f"{name:24s} {'slim':7s} | {'':8s} {'':6s} {'':5s} {'':8s} | {'':9s} {'':5s} {'':8s} | "
                  f"{cpu:10.2f} {it:5d} {worst:8.4f} {folds:5d}  (to Newton's energy per frame, at most 50 per frame)")
    print("\ntotals (CPU s, iterations)    search          texture         9 frames")
    for method, t in totals.items():
        print(f"{method:28s} {t[0]:7.2f} {t[1]:7.0f} {t[2]:7.2f} {t[3]:7.0f} {t[4]:7.2f} {t[5]:7.0f}")
    ratio = totals["newton"] / np.where(totals["lbfgs"] > 0, totals["lbfgs"], np.nan)  # nan: nothing to compare
    print(f"{'newton / lbfgs':28s} " + " ".join(f"{r:7.2f}" for r in ratio))


def run_searches(problems: list[tuple]) -> None:
    """Print per keyframe the Newton search's CPU seconds, iterations, topologies, energy and chosen cuts (the
    switch vertices and labels of every region), then the totals: compare two versions' lines for the same cuts."""
    total = np.zeros(2)
    for name, refined, me, other, skeleton, _, _ in problems:
        with IterationCount() as count:
            tpl, search_s = cpu_timed(lambda: optimize_topology(refined, me, other, skeleton))
        counts = [len(np.unique(j)) for j in refined.junctions]
        cuts = [(s.tolist(), a.tolist()) for s, a in zip(tpl.cut_switches, tpl.cut_assignment)]
        print(f"{name:32s} T-junctions {counts} | {search_s:6.2f} s {count.iterations:5d} it {tpl.trials:3d} topologies "
              f"energy {tpl.energy:8.4f} | cuts {cuts}", flush=True)
        total += [search_s, count.iterations]
    print(f"\ntotal: {total[0]:.2f} CPU s, {total[1]:.0f} iterations")


def main() -> None:
    """Parse flags and run."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--odd", action="store_true", help="synthetic: one T-junction in the region (the cusp search); "
                    "with --shots: one more on every region with an even count")
    ap.add_argument("--shots", default=None, help="a folder of shots (e.g. data_samples) instead of the synthetic one")
    ap.add_argument("--only", nargs="*", default=None, help="with --shots: these shots only")
    ap.add_argument("--slim", action="store_true", help="also libigl's SLIM on the frames")
    ap.add_argument("--search-only", action="store_true", help="only the Newton cut search, with the cuts it chose")
    args = ap.parse_args()
    problems = shot_problems(Path(args.shots), args.only, args.odd) if args.shots else synthetic_problems(args.odd)
    run(problems, args.slim, args.search_only)


if __name__ == "__main__":
    main()
