"""Benchmark RIFE on the CPU: seconds per midpoint at 256/384/512 px and one image-matrix build.

Run: .venv/bin/python benchmarks/bench_rife.py [--threads 2] [--repeats 5]
Target: the matrix of a 9-frame 384 x 384 shot at depth 3 (63 network calls) in <= 12 s on 2 cores.
Wall time on a shared machine is noisy; CPU seconds are printed beside it.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from scipy.ndimage import gaussian_filter

from ops.blending.image_matrix import build_image_matrix
from ops.blending.rife import Rife, load_rife


def smooth_frames(t: int, size: int, seed: int) -> np.ndarray:
    """(t, size, size, 4) float32 smooth random RGBA in [0, 1] (blurred noise, sigma 6 px)."""
    noise = np.random.default_rng(seed).random((t, size, size, 4), dtype=np.float32)
    f = gaussian_filter(noise, (0, 6, 6, 0))
    return ((f - f.min()) / (f.max() - f.min())).astype(np.float32)


def timed(fn) -> tuple[float, float]:
    """(wall seconds, process CPU seconds) of one call."""
    w, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w, time.process_time() - c


def bench_midpoint(rife: Rife, size: int, repeats: int) -> tuple[float, float, float]:
    """(median wall, min wall, median CPU) seconds of one 1-pair midpoint at size x size, after a warm-up."""
    a, b = smooth_frames(1, size, 1), smooth_frames(1, size, 2)
    rife.midpoint(a, b)
    runs = np.array([timed(lambda: rife.midpoint(a, b)) for _ in range(repeats)])
    return float(np.median(runs[:, 0])), float(runs[:, 0].min()), float(np.median(runs[:, 1]))


def bench_matrix(rife: Rife, frames: int, size: int, depth: int, batch: int) -> tuple[float, float]:
    """(wall, CPU) seconds of build_image_matrix for a frames x size x size shot."""
    f0, f1 = smooth_frames(frames, size, 3), smooth_frames(frames, size, 4)
    times = np.linspace(0.0, 1.0, frames)
    return timed(lambda: build_image_matrix(f0, f1, times, rife, depth=depth, batch=batch))


def main() -> None:
    """Print the timings."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--batches", type=int, nargs="+", default=[1, 8], help="pairs per network call to try for the matrix")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    rife = load_rife()
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, device {rife.device}")
    for size in (256, 384, 512):
        wall, best, cpu = bench_midpoint(rife, size, args.repeats)
        print(f"midpoint {size}x{size}: {wall:.3f} s wall (median of {args.repeats}, min {best:.3f}), "
              f"{cpu:.3f} s CPU")
    for batch in args.batches:
        wall, cpu = bench_matrix(rife, 9, 384, 3, batch)
        print(f"image matrix 9 frames 384x384 depth 3 batch {batch}: {wall:.2f} s wall, {cpu:.2f} s CPU "
              f"(63 midpoints, {wall / 63:.3f} s each; target <= 12 s)")


if __name__ == "__main__":
    main()
