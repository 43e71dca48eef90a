"""Benchmark RIFE on the CPU, torch against ONNX Runtime: seconds per midpoint at 256/384/512 px and one
image-matrix build, each runtime measured right after the other on the same inputs, and how far apart their
frames are (PSNR of one runtime's midpoint against the other's, dB; inf = identical).

Run: .venv/bin/python benchmarks/bench_rife.py [--threads 2] [--repeats 5] [--cache DIR]
Target: the matrix of a 9-frame 384 x 384 shot at depth 3 (63 network calls) in <= 12 s on 2 cores; the same
matrix with scaled cells (Settings.matrix_cells, the pipeline's: 9 calls, the other 54 cells from their flows)
is printed beside it.
Wall time on a shared machine is noisy; CPU seconds are printed beside it. The ONNX export is cached in
--cache (default: a temporary directory, so the first load pays the export, printed separately).
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import tempfile
import time

import numpy as np
import torch
from scipy.ndimage import gaussian_filter

from ops.blending.image_matrix import build_image_matrix
from ops.blending.rife import RUNTIMES, Rife, load_rife
from ops.blending.rife_onnx import limit_threads


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


def bench_matrix(rife: Rife, frames: int, size: int, depth: int, batch: int,
                 cells: str = "bisection") -> tuple[float, float]:
    """(wall, CPU) seconds of build_image_matrix, every cell, for a frames x size x size shot."""
    f0, f1 = smooth_frames(frames, size, 3), smooth_frames(frames, size, 4)
    times = np.linspace(0.0, 1.0, frames)
    return timed(lambda: build_image_matrix(f0, f1, times, rife, depth=depth, batch=batch, cells=cells))


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR (dB) of two float images in [0, 1]; inf if identical."""
    mse = float(np.mean((np.asarray(a, np.float64) - b) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(1.0 / mse)


def main() -> None:
    """Print the timings."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--batches", type=int, nargs="+", default=[1], help="pairs per network call to try for the matrix")
    ap.add_argument("--cache", default=None, help="directory of the ONNX export (default: a new temporary one)")
    args = ap.parse_args()
    limit_threads(args.threads)  # both runtimes
    with tempfile.TemporaryDirectory() as tmp:
        rifes = {}
        for runtime in RUNTIMES:
            wall, cpu = timed(lambda: rifes.setdefault(runtime, load_rife(runtime=runtime, cache_dir=args.cache or tmp)))
            print(f"load {runtime}: {wall:.2f} s wall, {cpu:.2f} s CPU"
                  + (" (exports the network unless --cache holds it)" if runtime == "onnxruntime" else ""))
        print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, device {rifes['torch'].device}")
        for size in (256, 384, 512):
            a, b = smooth_frames(1, size, 1), smooth_frames(1, size, 2)
            mids = {}
            for runtime, rife in rifes.items():
                wall, best, cpu = bench_midpoint(rife, size, args.repeats)
                mids[runtime] = rife.midpoint(a, b)[0]
                print(f"midpoint {size}x{size} {runtime:12s}: {wall:.3f} s wall (median of {args.repeats}, "
                      f"min {best:.3f}), {cpu:.3f} s CPU")
            print(f"  frames apart: {psnr(mids['torch'], mids['onnxruntime']):.1f} dB PSNR")
        for batch in args.batches:
            for runtime, rife in rifes.items():
                wall, cpu = bench_matrix(rife, 9, 384, 3, batch)
                print(f"image matrix 9 frames 384x384 depth 3 batch {batch} {runtime:12s}: {wall:.2f} s wall, "
                      f"{cpu:.2f} s CPU (63 midpoints, {wall / 63:.3f} s each; target <= 12 s)")
                wall, cpu = bench_matrix(rife, 9, 384, 3, batch, cells="scaled")
                print(f"  the same with scaled cells (the pipeline's): {wall:.2f} s wall, {cpu:.2f} s CPU "
                      f"(9 midpoints, 54 cells from their flows)")


if __name__ == "__main__":
    main()
