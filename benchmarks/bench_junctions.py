"""T-junction proposals against the generator's exact T-junctions: recall and precision at 5 px.

    python benchmarks/bench_junctions.py                     # tuning split and held-out split, 5 px
    python benchmarks/bench_junctions.py --train 50 --test 100 --radius 5 --rows

Truth: where the outline of a part meets the outline of a nearer, non-adjacent part that covers it, not
painted over by a third (data_samples/generator/occlusion.py: t_junctions; the same definition as the
sample shots' shot.json `t_junctions`), points of one keyframe closer than 2 px merged. Proposals come from
ops.segmentation.junction_proposals.propose_t_junctions on the masks the pipeline predicts
(ops.segmentation.masks.build_masks, the default "hybrid" occlusion), never on any ground truth. A proposal
matches a true junction within --radius px, one to one (minimum total distance).

Splits: tuning = the twelve sample shots' keyframes (data_samples/) plus the first --train samples of the
generated occlusion set's train split (seeds 0 ...); held-out = the first --test samples of its test split
(seeds 10 000 000 + index: other characters' proportions, poses, palettes and styles), generated in memory
and never used to choose any constant of the proposals. Printed per sample and per split: true junctions,
proposals, matches, recall and precision.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from data_samples.generator.occlusion_set import make_sample  # noqa: E402
from ops.segmentation.junction_proposals import features, line_map, propose_t_junctions, t_junction_candidates  # noqa: E402
from ops.segmentation.masks import build_masks  # noqa: E402
from ops.shotio.image_io import read_image  # noqa: E402
from ops.shotio.load import load_shot  # noqa: E402
from ops.types import Skeleton  # noqa: E402

TRUTH_MERGE_PX = 2.0  # the generator merges a pair's crossings this close; across pairs we do too


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


def sample_keyframes() -> list[tuple[str, np.ndarray, np.ndarray, Skeleton, np.ndarray]]:
    """(name, drawing (H, W, 3) float32, pose (J, 3), skeleton, true junctions (k, 2)) of the sample shots' keys."""
    out = []
    for d in sorted(p for p in (ROOT / "data_samples").iterdir() if (p / "shot.json").is_file()):
        data = json.loads((d / "shot.json").read_text())
        if data.get("masks"):  # manual masks: the pipeline does not predict this shot's occlusion
            continue
        shot = load_shot(d)
        for k in (0, 1):
            drawing = np.asarray(read_image(shot.keyframes[k]), np.float32)[..., :3]
            out.append((f"{d.name}/key{k}", drawing, shot.key_pose(k), shot.skeleton, merge_truth(shot.t_junctions[k])))
    return out


def generated(split: str, n: int):
    """The same tuple for the first n samples of the generated occlusion set's split (in memory)."""
    for i in range(n):
        s = make_sample(split, i)
        truth = [p["t_junctions"] for p in s.pairs if not p["adjacent"]]
        pts = np.concatenate([np.asarray(t, np.float64).reshape(-1, 2) for t in truth]) if truth else np.zeros((0, 2))
        skeleton = Skeleton(tuple(s.joints), np.asarray(s.parents, np.int64))
        yield (f"{split}_{i:04d} {s.label} {s.style}", s.image.astype(np.float32) / 255.0, s.pose, skeleton,
               merge_truth(pts))


def run_split(name: str, items, radius: float, rows: bool) -> tuple[int, int, int]:
    """Print one split's rows and totals; returns (true junctions, proposals, matches)."""
    total = np.zeros(3, np.int64)
    t0 = time.perf_counter()
    seconds = 0.0
    count = 0
    for label, drawing, pose, skeleton, truth in items:
        masks = build_masks(drawing, pose, skeleton, occlusion="hybrid")
        t1 = time.perf_counter()
        proposed = propose_t_junctions(masks, pose, skeleton).points
        seconds += time.perf_counter() - t1
        m = matches(truth, proposed, radius)
        total += (len(truth), len(proposed), m)
        count += 1
        if rows:
            rec = f"{m / len(truth):.2f}" if len(truth) else "   -"
            pre = f"{m / len(proposed):.2f}" if len(proposed) else "   -"
            print(f"  {label:<40} true {len(truth):>3}  proposed {len(proposed):>3}  matched {m:>3}  "
                  f"recall {rec}  precision {pre}")
    t, p, m = (int(v) for v in total)
    print(f"{name}: {count} keyframes, {t} true junctions, {p} proposals, {m} matched within {radius:g} px: "
          f"recall {m / max(t, 1):.3f}, precision {m / max(p, 1):.3f}  "
          f"(proposals {seconds / max(count, 1) * 1000:.0f} ms a keyframe, {time.perf_counter() - t0:.0f} s in all)")
    return t, p, m


def fit(items, radius: float, l2: float = 1e-2) -> np.ndarray:
    """Logistic weights of junction_proposals.FEATURES (Newton's method, L2 penalty l2) from the candidates
    of the items: a candidate is positive when a true junction lies within radius px."""
    X, Y = [], []
    for _, drawing, pose, skeleton, truth in items:
        masks = build_masks(drawing, pose, skeleton, occlusion="hybrid")
        cands = t_junction_candidates(line_map(masks.colour, masks.coverage))
        X.append(features(cands, masks, pose, skeleton))
        if len(truth) and len(cands.points):
            Y.append((np.linalg.norm(cands.points[:, None] - truth[None], axis=2).min(axis=1) <= radius).astype(float))
        else:
            Y.append(np.zeros(len(cands.points)))
    X, Y = np.concatenate(X), np.concatenate(Y)
    w = np.zeros(X.shape[1])
    for _ in range(50):
        p = 1.0 / (1.0 + np.exp(-X @ w))
        H = (X * (p * (1 - p))[:, None]).T @ X + l2 * np.eye(len(w))
        w -= np.linalg.solve(H, X.T @ (p - Y) + l2 * w)
    print(f"{len(Y)} candidates, {int(Y.sum())} within {radius:g} px of a true junction")
    return w


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", type=int, default=60, help="generated train-split samples in the tuning split")
    ap.add_argument("--test", type=int, default=100, help="generated test-split samples (held out)")
    ap.add_argument("--radius", type=float, default=5.0, help="match radius, pixels")
    ap.add_argument("--rows", action="store_true", help="one row per keyframe")
    ap.add_argument("--split", choices=("both", "tuning", "held-out"), default="both")
    ap.add_argument("--fit", action="store_true", help="fit the scoring's weights on the tuning split and print them")
    args = ap.parse_args(argv)
    if args.fit:
        w = fit(list(sample_keyframes()) + list(generated("train", args.train)), args.radius)
        print("WEIGHTS = np.array([" + ", ".join(f"{v:.2f}" for v in w) + "])")
        return
    if args.split in ("both", "tuning"):
        print("sample shots (tuning):")
        a = run_split("  sample shots", sample_keyframes(), args.radius, args.rows)
        print("generated train split (tuning):")
        b = run_split("  generated train", generated("train", args.train), args.radius, args.rows)
        t, p, m = (x + y for x, y in zip(a, b))
        print(f"TUNING overall: recall {m / max(t, 1):.3f}, precision {m / max(p, 1):.3f} ({m}/{t} true, {m}/{p} proposed)")
    if args.split in ("both", "held-out"):
        print("generated test split (held out, never tuned on):")
        t, p, m = run_split("  generated test", generated("test", args.test), args.radius, args.rows)
        print(f"HELD-OUT overall: recall {m / max(t, 1):.3f}, precision {m / max(p, 1):.3f} ({m}/{t} true, {m}/{p} proposed)")


if __name__ == "__main__":
    main()
