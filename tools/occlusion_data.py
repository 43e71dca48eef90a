"""Generated occlusion samples cached as compressed .npz files, for training and the benchmark.

Two generators: '2d' (data_samples/generator/occlusion_set.py: flat parts painted back to front, issue 15) and
'3d' (data_samples/generator/occlusion3d.py: posed 3D bodies with a depth buffer, posed by BVH clips when a
folder of them is given). One file per sample: image (H, W, 3) uint8 RGB, union (H, W) bool (every overlap,
joint overlaps included), fg (H, W) uint8 coverage x 255, pose (J, 3) float64 (x, y px; z, larger = farther),
parents (J,) int64, joints, label (class or body family), style, view ('' for 2d), pair_masks (P, H, W) bool
and pairs (JSON: per mask its front and back bone, adjacency; see the generators). Generating a sample costs
~0.2-0.5 s; reading a cached one ~5 ms.

    python tools/occlusion_data.py --split train --start 0 --n 4000 --out CACHE_DIR [--workers 2]
    python tools/occlusion_data.py --generator 3d --bvh BVH_DIR --split train --n 3000 --out CACHE_DIR

With --generator 3d, --start/--n count the split's trained-on indices (held-out families skipped) for the
train split, and every index for the test split. BVH_DIR: e.g. the AnimatedDrawings clips
(examples/bvh of facebookresearch/AnimatedDrawings); without it people are posed procedurally only.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script: the repository root holds data_samples/
    sys.path.insert(0, str(ROOT))

from data_samples.generator.occlusion3d import make_sample3d, train_indices  # noqa: E402
from data_samples.generator.occlusion_set import make_sample  # noqa: E402

GENERATORS = ("2d", "3d")


def cache_path(out: Path, split: str, index: int, generator: str = "2d") -> Path:
    """Where sample `index` of `split` of a generator is cached under `out`."""
    return out / (split if generator == "2d" else f"3d_{split}") / f"{index:08d}.npz"


def write_one(args: tuple) -> str:
    """Generate sample (split, index) of a generator and cache it (a worker's task); an existing file is kept."""
    split, index, out, generator, bvh = args
    path = cache_path(Path(out), split, index, generator)
    if path.exists():
        return str(path)
    s = make_sample(split, index) if generator == "2d" else make_sample3d(split, index, bvh)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    pair_masks = np.stack(s.occlusion) if s.occlusion else np.zeros((0, *s.image.shape[:2]), bool)
    np.savez_compressed(tmp, image=s.image, union=s.occlusion_union,
                        fg=np.round(np.clip(s.foreground, 0, 1) * 255).astype(np.uint8),
                        pose=np.asarray(s.pose, np.float64), parents=np.asarray(s.parents, np.int64),
                        label=s.label, style=s.style, view=getattr(s, "view", ""), joints=np.array(s.joints),
                        pair_masks=pair_masks, pairs=json.dumps(s.pairs))
    tmp.rename(path)
    return str(path)


def load(path: Path) -> dict:
    """A cached sample as a dict of arrays (label, style and view as str)."""
    with np.load(path) as z:
        d = {k: z[k] for k in z.files}
    d["label"], d["style"] = str(d["label"]), str(d["style"])
    d["view"] = str(d.get("view", ""))
    d["pairs"] = json.loads(str(d["pairs"])) if "pairs" in d else None
    return d


def ensure_indices(out: Path, split: str, indices: list[int], workers: int = 1, generator: str = "2d",
                   bvh: str | None = None) -> list[Path]:
    """Cache the given samples of `split` under `out` (generating the missing ones); their paths."""
    tasks = [(split, i, str(out), generator, bvh) for i in indices
             if not cache_path(out, split, i, generator).exists()]
    if tasks and workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            list(pool.map(write_one, tasks, chunksize=8))
    else:
        for t in tasks:
            write_one(t)
    return [cache_path(out, split, i, generator) for i in indices]


def ensure(out: Path, split: str, start: int, n: int, workers: int = 1, generator: str = "2d",
           bvh: str | None = None) -> list[Path]:
    """Cache samples start .. start + n - 1 of `split` (3d train: the n trained-on indices from `start`)."""
    if generator == "3d" and split == "train":
        indices = train_indices(n, start)
    else:
        indices = list(range(start, start + n))
    return ensure_indices(out, split, indices, workers, generator, bvh)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--generator", choices=GENERATORS, default="2d")
    ap.add_argument("--bvh", type=Path, default=None, help="folder of .bvh clips (3d generator)")
    ap.add_argument("--split", choices=("train", "test"), required=True)
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    ensure(args.out, args.split, args.start, args.n, args.workers, args.generator,
           str(args.bvh) if args.bvh else None)
    print(f"{args.n} {args.generator} {args.split} samples cached in {args.out} ({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
