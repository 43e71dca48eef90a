"""Train the T-junction network (ops/segmentation/junction_net.py) on generated characters, reproducibly.

Reproduces ops/segmentation/junction_unet.npz from the generators' train splits and their exact T-junctions
(the outline of a part ending against the outline of a part that covers it, for bones that share no joint):
the 2D generator (data_samples/generator/occlusion_set.py, occlusion.t_junctions) and the 3D one
(data_samples/generator/occlusion3d.py, junctions read off its depth buffer by junctions3d.py), of the 3D one
only the body and style families that are not held out (creature bodies and crayon drawings never appear),
and plain geometric drawings (data_samples/generator/junction_primitives.py: a bar or an ellipse over a disc or a
rectangle, texture strokes crossing on a body), which keep a longer schedule from reading every round outline of
the generators' as a junction.
Test splits are never read. Fixed seeds for the crops, augmentation and initialisation; torch on the CPU with a
fixed thread count. At the end it writes the weights, patches WEIGHTS_SHA256 in junction_infer.py (so the
stages using the network get a new code version) and prints recall and precision at 5 px on the tuning sets
(train-split samples after the trained ones, and plain drawings after the trained ones: never trained on) for a
sweep of thresholds.

    python tools/train_junctions.py --cache CACHE_DIR --bvh BVH_DIR   # the shipped weights (docs/weights.md)
    python tools/train_junctions.py --cache OTHER_CACHE [--samples 1500] [--samples3d 3000] [--primitives 800] \
        [--steps 20000]   # without --bvh: people posed procedurally only; use a cache of its own

The held-out figures are benchmarks/bench_junctions.py's. Samples missing from the cache are generated first
(tools/occlusion_data.py: the same cache as the occlusion network's, whose 3D samples carry their junctions).
CPU convolutions are not bitwise deterministic across machines or thread counts, so a rerun reproduces the
weights' quality, not their bytes.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import math
import re
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from data_samples.generator.junction_primitives import make_primitive  # noqa: E402
from ops.segmentation.junction_infer import (  # noqa: E402
    IN_CHANNELS,
    junction_frame,
    junction_input,
)
from ops.segmentation.junction_net import WEIGHTS_PATH, JunctionUNet, save_weights  # noqa: E402
from ops.segmentation.junction_proposals import heat_peaks, junction_maps  # noqa: E402
from ops.segmentation.network_input import to_work  # noqa: E402
from ops.types import Skeleton  # noqa: E402
from tools.occlusion_data import ensure, load  # noqa: E402

SEED = 27
ZOOM_JITTER = 0.25  # log-uniform zoom factor in exp(+-this) around the working zoom
DROP_DEPTH = 0.15  # share of crops whose depth channels are zeroed (skeletons without z)
SIGMA = 1.5  # working px: the heatmap's Gaussian around each true junction
NEAR_JUNCTION = 0.6  # share of crops centred near a true junction (they are rare pixels)
STEM_RADIUS = 2.0  # working px: the stem output is trained this close to a junction
STEM_WEIGHT = 0.5
MATCH_PX = 5.0  # the benchmark's radius (keyframe px)
GOAL = (0.8, 0.6)  # recall and precision at MATCH_PX asked of the proposals (issue 27)
TUNE_2D_START = 9000  # the tuning set: 2D train-split samples from here (the training reads 0 .. --samples - 1)
TUNE_3D_START = 9000  # ... and the 3D train split's trained-on indices from index 9000
TUNE_PRIMITIVE_START = 100_000  # ... and plain drawings from here (the training reads 0 .. --primitives - 1)


def truth_of(sample: dict) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) px T-junctions of the bone pairs that share no joint and (k, 2) their stems, from a cached sample."""
    pts, stems = [], []
    for p in sample["pairs"]:
        if p["adjacent"]:
            continue
        if "t_stems" not in p:
            raise SystemExit("the sample cache predates T-junction stems; fix: regenerate it (a new --cache folder)")
        for q, s in zip(p["t_junctions"], p["t_stems"]):
            if all(np.hypot(q[0] - r[0], q[1] - r[1]) >= 2.0 for r in pts):  # the benchmark merges at 2 px
                pts.append(q)
                stems.append(s)
    return np.asarray(pts, np.float64).reshape(-1, 2), np.asarray(stems, np.float64).reshape(-1, 2)


def skeleton_of(sample: dict) -> Skeleton:
    return Skeleton(tuple(str(i) for i in range(len(sample["parents"]))), np.asarray(sample["parents"], np.int64))


def prepare(sample: dict, rng: np.random.Generator | None) -> dict:
    """A sample at its (jittered) working scale: x (IN_CHANNELS, h, w) int8 (x 127), junctions (k, 2) working
    px, stems (k, 2). rng None: no jitter."""
    fg = sample["fg"] > 127
    frame = junction_frame(fg, sample["pose"])
    if rng is not None:
        frame.zoom *= float(np.exp(rng.uniform(-ZOOM_JITTER, ZOOM_JITTER)))
    x = junction_input(sample["image"], frame, sample["pose"], skeleton_of(sample))
    pts, stems = truth_of(sample)
    work = to_work(np.c_[pts, np.zeros(len(pts))], frame)[:, :2] if len(pts) else pts
    return {"x": np.round(np.clip(x, -1, 1) * 127).astype(np.int8), "pts": work, "stems": stems}


def targets(pts: np.ndarray, stems: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(h, w) heat target (1 at each junction's pixel, a Gaussian of SIGMA around it), (2, h, w) stem target and
    (h, w) its weight, for junctions pts (k, 2) x, y in the crop's pixels."""
    h, w = shape
    heat = np.zeros(shape, np.float32)
    stem = np.zeros((2, h, w), np.float32)
    weight = np.zeros(shape, np.float32)
    r = int(math.ceil(3 * SIGMA))
    for (x, y), s in zip(pts, stems):
        cx, cy = int(round(x)), int(round(y))
        y0, y1, x0, x1 = max(cy - r, 0), min(cy + r + 1, h), max(cx - r, 0), min(cx + r + 1, w)
        if y0 >= y1 or x0 >= x1:
            continue
        yy, xx = np.mgrid[y0:y1, x0:x1]
        g = np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * SIGMA**2)).astype(np.float32)
        heat[y0:y1, x0:x1] = np.maximum(heat[y0:y1, x0:x1], g)
        near = ((xx - x) ** 2 + (yy - y) ** 2) <= STEM_RADIUS**2
        stem[0, y0:y1, x0:x1][near] = s[0]
        stem[1, y0:y1, x0:x1][near] = s[1]
        weight[y0:y1, x0:x1][near] = 1.0
    return heat, stem, weight


def crop(item: dict, rng: np.random.Generator, size: int) -> tuple[np.ndarray, ...]:
    """A random size x size training example: input (IN_CHANNELS, s, s), heat (1, s, s), stem (2, s, s),
    stem weight (1, s, s); augmented (mirror, palette, grey, contrast, blur, noise, no depth)."""
    xi = item["x"]
    _, h, w = xi.shape
    pts, stems = item["pts"], item["stems"]
    if len(pts) and rng.random() < NEAR_JUNCTION:
        k = int(rng.integers(len(pts)))
        cx, cy = pts[k] + rng.uniform(-size / 3, size / 3, 2)
    else:
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
    x0, y0 = int(round(cx)) - size // 2, int(round(cy)) - size // 2
    x = np.zeros((IN_CHANNELS, size, size), np.float32)
    sy0, sx0, sy1, sx1 = max(y0, 0), max(x0, 0), min(y0 + size, h), min(x0 + size, w)
    if sy1 > sy0 and sx1 > sx0:
        x[:, sy0 - y0:sy1 - y0, sx0 - x0:sx1 - x0] = xi[:, sy0:sy1, sx0:sx1] / 127.0
    local = pts - (x0, y0)
    heat, stem, weight = targets(local, stems, (size, size))
    if rng.random() < 0.5:  # mirror: the skeleton channels are mirror-symmetric; the stems' x turns
        x, heat, stem, weight = x[:, :, ::-1], heat[:, ::-1], stem[:, :, ::-1], weight[:, ::-1]
        stem = stem * np.array([-1.0, 1.0], np.float32)[:, None, None]
    x = np.ascontiguousarray(x)
    x[:3] = x[rng.permutation(3)] * rng.uniform(0.7, 1.3)  # other palettes, paler or stronger drawings
    if rng.random() < 0.2:  # a grey drawing (pencil, a scan in black and white)
        x[:3] = x[:3].mean(axis=0, keepdims=True)
    if rng.random() < 0.3:  # contrast: faint pencil or heavy marker
        x[:3] = np.sign(x[:3]) * np.abs(x[:3]) ** rng.uniform(0.7, 1.4)
    if rng.random() < 0.15:  # softer lines (a blurred photograph)
        sigma = rng.uniform(0.4, 1.0)
        x[:3] = np.stack([cv2.GaussianBlur(np.ascontiguousarray(c), (0, 0), sigma) for c in x[:3]])
    x[:3] += rng.normal(0, rng.uniform(0, 0.03), (3, size, size)).astype(np.float32)
    np.clip(x[:3], -1, 1, out=x[:3])
    if rng.random() < DROP_DEPTH:
        x[3 + 3: 3 + 5] = 0.0
    return (x, np.ascontiguousarray(heat[None]), np.ascontiguousarray(stem), np.ascontiguousarray(weight[None]))


def focal_loss(logits: torch.Tensor, heat: torch.Tensor) -> torch.Tensor:
    """CenterNet's penalty-reduced focal loss of heat logits (N, 1, H, W) against a Gaussian target, per junction."""
    p = torch.sigmoid(logits).clamp(1e-4, 1 - 1e-4)
    pos = heat >= 0.999
    pos_loss = -((1 - p) ** 2 * torch.log(p))[pos].sum()
    neg_loss = -((1 - heat) ** 4 * p**2 * torch.log(1 - p))[~pos].sum()
    return (pos_loss + neg_loss) / pos.sum().clamp(min=1)


def loss_fn(out: torch.Tensor, heat: torch.Tensor, stem: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
    """Focal loss of the heat plus STEM_WEIGHT x the stems' mean squared error near junctions."""
    stem_err = ((torch.tanh(out[:, 1:3]) - stem) ** 2).sum(1, keepdim=True)
    stem_loss = (stem_err * weight).sum() / weight.sum().clamp(min=1)
    return focal_loss(out[:, :1], heat) + STEM_WEIGHT * stem_loss


def set_sha(digest: str) -> None:
    """Write the new weights' sha256 into ops/segmentation/junction_infer.py."""
    path = ROOT / "ops" / "segmentation" / "junction_infer.py"
    text = path.read_text()
    text = re.sub(r'WEIGHTS_SHA256 = "[0-9a-f]{64}"', f'WEIGHTS_SHA256 = "{digest}"', text)
    path.write_text(text)


def match_count(truth: np.ndarray, proposed: np.ndarray, radius: float) -> int:
    """How many proposals (p, 2) match a true junction (t, 2) within radius px, one to one."""
    from scipy.optimize import linear_sum_assignment

    if not len(truth) or not len(proposed):
        return 0
    d = np.linalg.norm(truth[:, None, :] - proposed[None, :, :], axis=2)
    r, c = linear_sum_assignment(np.where(d <= radius, d, 1e6))
    return int((d[r, c] <= radius).sum())


def tune(weights: Path, samples: list[dict], thresholds: np.ndarray) -> list[tuple[float, int, int, int]]:
    """(threshold, true, proposed, matched) per threshold on samples (true foreground, the drawing itself), read
    as the proposals read a keyframe (junction_proposals.junction_maps, heat_peaks) with a weights file; prints
    the sweep."""
    from ops.segmentation.junction_infer import file_sha256, to_keyframe

    use = (str(weights), file_sha256(weights))
    rows = np.zeros((len(thresholds), 3), np.int64)
    for d in samples:
        heat, _, frame = junction_maps(d["image"], d["fg"] > 127, d["pose"], skeleton_of(d), use)
        pts, scores = heat_peaks(heat, float(thresholds.min()))
        pts = to_keyframe(pts, frame)
        truth, _ = truth_of(d)
        for i, t in enumerate(thresholds):
            keep = pts[scores >= t]
            rows[i] += (len(truth), len(keep), match_count(truth, keep, MATCH_PX))
    out = []
    for t, (n_true, n_prop, m) in zip(thresholds, rows):
        rec, pre = m / max(n_true, 1), m / max(n_prop, 1)
        print(f"  threshold {t:.3f}: recall {rec:.3f} precision {pre:.3f} ({m}/{n_true} true, {n_prop} proposed)")
        out.append((float(t), int(n_true), int(n_prop), int(m)))
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, required=True, help="sample cache (tools/occlusion_data.py)")
    ap.add_argument("--samples", type=int, default=1500, help="2D train samples 0 .. N-1")
    ap.add_argument("--samples3d", type=int, default=3000, help="3D train samples (the first N trained-on indices)")
    ap.add_argument("--share3d", type=float, default=0.6, help="share of the generators' crops from the 3D samples")
    ap.add_argument("--primitives", type=int, default=800, help="plain geometric drawings 0 .. N-1")
    ap.add_argument("--share-primitives", type=float, default=0.1,
                    help="share of each batch's crops from the plain drawings")
    ap.add_argument("--steps", type=int, default=20000, help="length of the learning-rate schedule")
    ap.add_argument("--stop-after", type=int, default=None, help="end training after this many steps")
    ap.add_argument("--batch", type=int, default=12)
    ap.add_argument("--crop", type=int, default=96, help="training crop side, working pixels")
    ap.add_argument("--lr", type=float, default=3e-3)
    ap.add_argument("--threads", type=int, default=1, help="torch threads (one: less CPU time on a busy machine)")
    ap.add_argument("--out", type=Path, default=WEIGHTS_PATH)
    ap.add_argument("--workers", type=int, default=1, help="processes generating missing samples")
    ap.add_argument("--bvh", type=Path, default=None,
                    help="folder of .bvh clips that pose the 3D generator's people in the trained-on samples (the "
                         "tuning samples stay posed procedurally); use a cache of its own")
    ap.add_argument("--tune-n", type=int, default=100, help="tuning samples per generator (train split, untrained)")
    ap.add_argument("--tune-only", action="store_true", help="only print the tuning sweep of --out")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    if not args.tune_only:
        train(args)
    tuning = [load(p) for p in ensure(args.cache, "train", TUNE_2D_START, args.tune_n, args.workers)]
    tuning3d = [load(p) for p in ensure(args.cache, "train", TUNE_3D_START, args.tune_n, args.workers, "3d")]
    thresholds = np.round(np.arange(0.1, 0.6, 0.025), 3)
    print(f"tuning: 2D train split {TUNE_2D_START}-{TUNE_2D_START + args.tune_n - 1} (never trained on), "
          "true foreground")
    a = tune(args.out, tuning, thresholds)
    print(f"tuning: 3D train split, trained-on families, from index {TUNE_3D_START} (never trained on)")
    b = tune(args.out, tuning3d, thresholds)
    print(f"tuning: plain drawings {TUNE_PRIMITIVE_START}-{TUNE_PRIMITIVE_START + args.tune_n - 1} (never trained "
          "on; a check, not in the rule below)")
    tune(args.out, [make_primitive(TUNE_PRIMITIVE_START + i) for i in range(args.tune_n)], thresholds)
    both = []
    for (t, n2, p2, m2), (_, n3, p3, m3) in zip(a, b):
        rec, pre = (m2 + m3) / max(n2 + n3, 1), (m2 + m3) / max(p2 + p3, 1)
        both.append((t, rec, pre))
        print(f"  both, threshold {t:.3f}: recall {rec:.3f} precision {pre:.3f} recall x precision {rec * pre:.3f}")
    meets = [t for t, rec, pre in both if rec >= GOAL[0] and pre >= GOAL[1]]
    span = f"{min(meets):.3f} to {max(meets):.3f}, the middle {meets[len(meets) // 2]:.3f}" if meets else "none"
    print(f"thresholds with recall >= {GOAL[0]} and precision >= {GOAL[1]} on the 2D and 3D tuning sets together: "
          f"{span} (junction_proposals.MIN_SCORE is set by hand to the middle)")


def train(args: argparse.Namespace) -> None:
    """Train from scratch on the cached samples and write the weights (and their sha256, for the shipped file)."""
    torch.manual_seed(SEED)
    rng = np.random.default_rng(SEED)
    t0 = time.perf_counter()
    c0 = time.process_time()
    paths2d = ensure(args.cache, "train", 0, args.samples, args.workers) if args.samples else []
    bvh = str(args.bvh) if args.bvh else None
    paths3d = ensure(args.cache, "train", 0, args.samples3d, args.workers, "3d", bvh) if args.samples3d else []
    items2d = [prepare(load(p), rng) for p in paths2d]
    items3d = [prepare(load(p), rng) for p in paths3d]
    plain = [prepare(make_primitive(i), rng) for i in range(args.primitives)]
    n_true = sum(len(i["pts"]) for i in items2d + items3d + plain)
    print(f"{len(items2d)} 2D, {len(items3d)} 3D and {len(plain)} plain samples ({n_true} junctions) prepared in "
          f"{time.process_time() - c0:.0f} CPU s", flush=True)
    rest = 1 - args.share_primitives
    pools = [(items, share) for items, share in ((items3d, args.share3d * rest), (items2d, (1 - args.share3d) * rest),
                                                 (plain, args.share_primitives)) if items and share > 0]
    shares = np.array([share for _, share in pools]) / sum(share for _, share in pools)
    net = JunctionUNet().to(memory_format=torch.channels_last)
    opt = torch.optim.AdamW(net.parameters(), lr=args.lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda s: min(1.0, (s + 1) / 100) * 0.5 * (1 + math.cos(math.pi * s / args.steps)))
    net.train()
    t0, c0, running = time.perf_counter(), time.process_time(), 0.0
    for step in range(min(args.steps, args.stop_after or args.steps)):
        batch = []
        for _ in range(args.batch):
            items = pools[int(rng.choice(len(pools), p=shares))][0]
            batch.append(crop(items[int(rng.integers(len(items)))], rng, args.crop))
        x, heat, stem, weight = (torch.from_numpy(np.stack([b[i] for b in batch])) for i in range(4))
        loss = loss_fn(net(x.contiguous(memory_format=torch.channels_last)), heat, stem, weight)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        running = 0.98 * running + 0.02 * loss.item() if step else loss.item()
        if step % 100 == 0 or step == args.steps - 1:
            print(f"step {step:5d}  loss {running:.4f}  lr {sched.get_last_lr()[0]:.2e}  "
                  f"{time.process_time() - c0:.0f} CPU s ({time.perf_counter() - t0:.0f} s)", flush=True)
        if (step + 1) % 1000 == 0:
            save_weights(net, args.cache / "junction_unet.partial.npz")  # a checkpoint to look at
    print(f"trained in {time.process_time() - c0:.0f} CPU s", flush=True)
    digest = save_weights(net, args.out)
    if args.out == WEIGHTS_PATH:
        set_sha(digest)
    print(f"weights {args.out} sha256 {digest} ({args.out.stat().st_size / 1e6:.2f} MB)", flush=True)


if __name__ == "__main__":
    main()
