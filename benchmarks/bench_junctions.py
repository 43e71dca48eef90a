"""T-junction proposals against the generators' exact T-junctions: recall and precision at 5 px.

    python benchmarks/bench_junctions.py                     # tuning and held-out splits, 5 px
    python benchmarks/bench_junctions.py --test 100 --test3d 60 --radius 5 --rows
    python benchmarks/bench_junctions.py --speed             # CPU seconds of one keyframe at 256 and 512 px

Truth: where the outline of a part meets the outline of a nearer part that shares no joint with it and covers
it, not painted over by a third (data_samples/generator/occlusion.py: t_junctions, the sample shots' shot.json
`t_junctions`; for the 3D generator the same read off its depth buffer, data_samples/generator/junctions3d.py),
points of one keyframe closer than 2 px merged. Proposals come from
ops.segmentation.junction_proposals.propose_t_junctions on the masks the pipeline predicts
(ops.segmentation.masks.build_masks, the default "hybrid" occlusion), never on any ground truth. A proposal
matches a true junction within --radius px, one to one (minimum total distance).

Splits:
- tuning: the sample shots' keyframes (data_samples/, manual masks left out) and --train samples of each
  generator's train split from index 9000 (tools/train_junctions.py trains on lower indices and chooses its
  threshold on these);
- held out (never trained or tuned on): the first --test samples of the 2D generator's test split (seeds
  10 000 000 + index), and --test3d samples of each of the 3D generator's test sets: the body and style
  families training sees, the held-out body family (creature) and the held-out style family (crayon).
Printed per split, per style and (--rows) per keyframe: true junctions, proposals, matches, recall,
precision, and the proposals' CPU time per keyframe.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import json
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from data_samples.generator.occlusion3d import held_out_indices, make_sample3d, train_indices  # noqa: E402
from data_samples.generator.occlusion_set import make_sample  # noqa: E402
from ops.segmentation.junction_proposals import propose_t_junctions  # noqa: E402
from ops.segmentation.masks import build_masks  # noqa: E402
from ops.shotio.image_io import read_image  # noqa: E402
from ops.shotio.load import load_shot  # noqa: E402
from ops.types import Skeleton  # noqa: E402

TRUTH_MERGE_PX = 2.0  # the generator merges a pair's crossings this close; across pairs we do too
TUNE_START = 9000  # the tuning samples' first train-split index (tools/train_junctions.py: TUNE_*_START)


def merge_truth(points: np.ndarray) -> np.ndarray:
    """(k', 2) the true junctions (k, 2) with points closer than TRUTH_MERGE_PX to an earlier one dropped."""
    kept: list[np.ndarray] = []
    for p in np.asarray(points, np.float64).reshape(-1, 2):
        if all(np.linalg.norm(p - q) >= TRUTH_MERGE_PX for q in kept):
            kept.append(p)
    return np.asarray(kept, np.float64).reshape(-1, 2)


def matches(truth: np.ndarray, proposed: np.ndarray, radius: float) -> int:
    """How many proposals (p, 2) match a true junction (t, 2) within radius px, one to one."""
    if not len(truth) or not len(proposed):
        return 0
    d = np.linalg.norm(truth[:, None, :] - proposed[None, :, :], axis=2)
    cost = np.where(d <= radius, d, 1e6)
    r, c = linear_sum_assignment(cost)
    return int((d[r, c] <= radius).sum())


def sample_keyframes():
    """(name, style, drawing (H, W, 3) float32, pose (J, 3), skeleton, true junctions (k, 2)) of the sample
    shots' keys."""
    for d in sorted(p for p in (ROOT / "data_samples").iterdir() if (p / "shot.json").is_file()):
        data = json.loads((d / "shot.json").read_text())
        if data.get("masks"):  # manual masks: the pipeline does not predict this shot's occlusion
            continue
        shot = load_shot(d)
        for k in range(shot.n_keys):
            drawing = np.asarray(read_image(shot.keyframes[k]), np.float32)[..., :3]
            yield (f"{d.name}/key{k}", d.name, drawing, shot.key_pose(k), shot.skeleton,
                   merge_truth(shot.t_junctions[k]))


def _truth(pairs: list[dict]) -> np.ndarray:
    pts = [np.asarray(p["t_junctions"], np.float64).reshape(-1, 2) for p in pairs if not p["adjacent"]]
    return merge_truth(np.concatenate(pts)) if pts else np.zeros((0, 2))


def generated(split: str, indices):
    """The same tuple for samples of the 2D generator's split (in memory)."""
    for i in indices:
        s = make_sample(split, i)
        skeleton = Skeleton(tuple(s.joints), np.asarray(s.parents, np.int64))
        yield (f"{split}_{i:04d} {s.label} {s.style}", s.style, s.image.astype(np.float32) / 255.0, s.pose,
               skeleton, _truth(s.pairs))


def generated3d(split: str, indices):
    """The same tuple for samples of the 3D generator's split (in memory; people posed procedurally)."""
    for i in indices:
        s = make_sample3d(split, i)
        skeleton = Skeleton(tuple(s.joints), np.asarray(s.parents, np.int64))
        yield (f"3d_{split}_{i:04d} {s.label} {s.style} {s.view}", s.style, s.image.astype(np.float32) / 255.0,
               s.pose, skeleton, _truth(s.pairs))


def run_split(name: str, items, radius: float, rows: bool, styles: bool = True) -> np.ndarray:
    """Print one split's rows, per-style totals and totals; returns (true junctions, proposals, matches)."""
    total = np.zeros(3, np.int64)
    per_style: dict[str, np.ndarray] = defaultdict(lambda: np.zeros(3, np.int64))
    seconds, count = 0.0, 0
    for label, style, drawing, pose, skeleton, truth in items:
        masks = build_masks(drawing, pose, skeleton, occlusion="hybrid")
        c0 = time.process_time()
        proposed = propose_t_junctions(masks, pose, skeleton).points
        seconds += time.process_time() - c0
        m = matches(truth, proposed, radius)
        row = np.array([len(truth), len(proposed), m])
        total += row
        per_style[style] += row
        count += 1
        if rows:
            rec = f"{m / len(truth):.2f}" if len(truth) else "   -"
            pre = f"{m / len(proposed):.2f}" if len(proposed) else "   -"
            print(f"  {label:<48} true {len(truth):>3}  proposed {len(proposed):>3}  matched {m:>3}  "
                  f"recall {rec}  precision {pre}")
    if styles:
        for style in sorted(per_style):
            t, p, m = (int(v) for v in per_style[style])
            print(f"    {style:<14} true {t:>4}  proposed {p:>4}  matched {m:>4}  recall {m / max(t, 1):.3f}  "
                  f"precision {m / max(p, 1):.3f}")
    t, p, m = (int(v) for v in total)
    print(f"{name}: {count} keyframes, {t} true junctions, {p} proposals, {m} matched within {radius:g} px: "
          f"recall {m / max(t, 1):.3f}, precision {m / max(p, 1):.3f}  "
          f"(proposals {seconds / max(count, 1):.3f} CPU s a keyframe)", flush=True)
    return total


def _overall(label: str, totals: list[np.ndarray]) -> None:
    t, p, m = (int(v) for v in np.sum(totals, axis=0))
    print(f"{label}: recall {m / max(t, 1):.3f}, precision {m / max(p, 1):.3f} ({m}/{t} true, {m}/{p} proposed)")


def speed(sizes: tuple[int, ...] = (256, 512), repeats: int = 9) -> None:
    """Print the proposals' CPU seconds on one keyframe (the 2D test split's first sample, scaled so its longer
    side is each size), median of `repeats` runs after a first one (weights loaded)."""
    import cv2

    s = make_sample("test", 0)
    skeleton = Skeleton(tuple(s.joints), np.asarray(s.parents, np.int64))
    for size in sizes:
        k = size / max(s.image.shape[:2])
        img = cv2.resize(s.image, None, fx=k, fy=k, interpolation=cv2.INTER_CUBIC).astype(np.float32) / 255.0
        pose = s.pose.copy()
        pose[:, :2] *= k
        masks = build_masks(img, pose, skeleton, occlusion="hybrid")
        propose_t_junctions(masks, pose, skeleton)
        cpu = []
        for _ in range(repeats):
            c0 = time.process_time()
            propose_t_junctions(masks, pose, skeleton)
            cpu.append(time.process_time() - c0)
        print(f"speed: a {img.shape[1]} x {img.shape[0]} keyframe, proposals {np.median(cpu):.3f} CPU s "
              f"(median of {repeats}; least {min(cpu):.3f}; load average {os.getloadavg()[0]:.1f})")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", type=int, default=60, help="tuning samples of each generator's train split")
    ap.add_argument("--test", type=int, default=100, help="2D test-split samples (held out)")
    ap.add_argument("--test3d", type=int, default=60, help="3D test-split samples per set (held out)")
    ap.add_argument("--radius", type=float, default=5.0, help="match radius, pixels")
    ap.add_argument("--rows", action="store_true", help="one row per keyframe")
    ap.add_argument("--split", choices=("both", "tuning", "held-out"), default="both")
    ap.add_argument("--speed", action="store_true", help="only the CPU time of one keyframe at 256 and 512 px")
    args = ap.parse_args(argv)
    if args.speed:
        speed()
        return
    r = args.radius
    if args.split in ("both", "tuning"):
        print("sample shots (tuning):")
        a = run_split("  sample shots", sample_keyframes(), r, args.rows, styles=False)
        print(f"generated 2D train split {TUNE_START}- (tuning, never trained on):")
        b = run_split("  generated 2D train", generated("train", range(TUNE_START, TUNE_START + args.train)), r,
                      args.rows)
        print(f"generated 3D train split from index {TUNE_START}, trained-on families (tuning, never trained on):")
        c = run_split("  generated 3D train", generated3d("train", train_indices(args.train, TUNE_START)), r,
                      args.rows)
        _overall("TUNING overall", [a, b, c])
    if args.split in ("both", "held-out"):
        print("generated 2D test split (held out, never tuned on):")
        t2 = run_split("  generated 2D test", generated("test", range(args.test)), r, args.rows)
        _overall("HELD-OUT 2D", [t2])
        if args.test3d:
            sets = (("seen", "3D test, seen body and style families"), ("body", "3D test, held-out body (creature)"),
                    ("style", "3D test, held-out style (crayon)"))
            for kind, name in sets:
                print(f"generated {name} (held out):")
                run_split(f"  {name}", generated3d("test", held_out_indices(kind, args.test3d)), r, args.rows)


if __name__ == "__main__":
    main()
