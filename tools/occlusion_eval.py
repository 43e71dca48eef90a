"""Occlusion predictors scored on data never trained on: the validation sets of the training script and the benchmark.

Four sets, all from the generators' test splits (seeds 10 000 000 + index, never trained or tuned on):
- '2d test': the 2D generator's test split (data_samples/generator/occlusion_set.py), today's benchmark;
- '3d seen': the 3D generator's test split, body and style families that training sees;
- '3d held-out body': the body family no training sample has (occlusion3d.HELD_OUT_FAMILY, tailed bipeds);
- '3d held-out style': the style family no training sample has (occlusion3d.HELD_OUT_STYLE, crayon).
The score is the IoU of a predictor's union of regions against the union of the truth (every overlap of two
bones' shapes, joint overlaps included), per keyframe with an occlusion, averaged; given the true foreground.

    python tools/occlusion_eval.py --cache CACHE_DIR --bvh BVH_DIR [--n 60] [--weights W.npz]
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import statistics
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from data_samples.generator.occlusion3d import HELD_OUT_FAMILY, HELD_OUT_STYLE, held_out_indices  # noqa: E402
from ops.types import Skeleton  # noqa: E402
from tools.occlusion_data import ensure_indices, load  # noqa: E402

SETS = ("2d test", "3d seen", "3d held-out body", "3d held-out style")
SET_NOTES = {"3d held-out body": f"({HELD_OUT_FAMILY})", "3d held-out style": f"({HELD_OUT_STYLE})"}
Predictor = Callable[[np.ndarray, np.ndarray, np.ndarray, Skeleton], np.ndarray]


def set_indices(name: str, n: int) -> tuple[str, list[int]]:
    """The generator ('2d' or '3d') and the test-split indices of a validation set."""
    if name == "2d test":
        return "2d", list(range(n))
    kind = {"3d seen": "seen", "3d held-out body": "body", "3d held-out style": "style"}[name]
    return "3d", held_out_indices(kind, n)


def load_set(name: str, n: int, cache: Path, bvh: str | None, workers: int = 1) -> list[dict]:
    """The cached samples of a validation set (generated first where missing), with a Skeleton each."""
    generator, indices = set_indices(name, n)
    items = []
    for path in ensure_indices(cache, "test", indices, workers, generator, bvh):
        d = load(path)
        d["skeleton"] = Skeleton(tuple(str(j) for j in d.get("joints", range(len(d["parents"])))), d["parents"])
        d["set"] = name
        items.append(d)
    return items


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two (H, W) bool masks (1 when both are empty)."""
    union = (a | b).sum()
    return float((a & b).sum() / union) if union else 1.0


def union_of(regions: list[np.ndarray], shape: tuple[int, int]) -> np.ndarray:
    """(H, W) bool union of regions."""
    out = np.zeros(shape, bool)
    for r in regions:
        out |= r
    return out


def network_regions(image: np.ndarray, fg: np.ndarray, pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """The network's regions (occlusion_drawing.predict_occlusion, joint overlaps included): its own figure."""
    from ops.segmentation.occlusion_drawing import predict_occlusion

    return union_of(predict_occlusion(image, fg, pose, skeleton)[0], fg.shape)


def score_items(items: list[dict], predict: Predictor) -> list[float]:
    """Per item with an occlusion, the IoU of `predict` (given the true foreground) against the truth."""
    out = []
    for d in items:
        if not d["union"].any():
            continue
        fg = d["fg"] > 127
        out.append(iou(predict(d["image"], fg, d["pose"], d["skeleton"]), d["union"]))
    return out


def validate(n: int, cache: Path, bvh: str | None, predictors: dict[str, Predictor], workers: int = 1,
             sets: tuple[str, ...] = SETS) -> dict[str, dict[str, float]]:
    """{set: {predictor: mean IoU}} over n samples of each validation set; prints a table."""
    table: dict[str, dict[str, float]] = {}
    for name in sets:
        items = load_set(name, n, cache, bvh, workers)
        table[name] = {p: statistics.fmean(score_items(items, f)) for p, f in predictors.items()}
    print("\n| validation set (never trained on) | n | " + " | ".join(predictors) + " |")
    print("|---|---|" + "---|" * len(predictors))
    for name, row in table.items():
        print(f"| {name} {SET_NOTES.get(name, '')} | {n} | " + " | ".join(f"{v:.3f}" for v in row.values()) + " |")
    return table


def use_weights(path: Path) -> str:
    """Make the NumPy inference read a candidate weights file (its own sha256); returns the digest."""
    from ops.segmentation import occlusion_infer

    digest = occlusion_infer.file_sha256(path)
    occlusion_infer.WEIGHTS_PATH, occlusion_infer.WEIGHTS_SHA256 = Path(path), digest
    return digest


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, required=True, help="sample cache (tools/occlusion_data.py)")
    ap.add_argument("--bvh", type=Path, default=None, help="folder of .bvh clips (as the training data had)")
    ap.add_argument("--n", type=int, default=60, help="samples per validation set")
    ap.add_argument("--weights", type=Path, default=None, help="a candidate weights file (default: the shipped one)")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args(argv)
    if args.weights:
        print(f"weights {args.weights} sha256 {use_weights(args.weights)}")
    validate(args.n, args.cache, str(args.bvh) if args.bvh else None, {"network": network_regions}, args.workers)


if __name__ == "__main__":
    main()
