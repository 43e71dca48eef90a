"""Train the occlusion network (ops/segmentation/occlusion_net.py) on generated characters, reproducibly.

Reproduces ops/segmentation/occlusion_unet.npz from the generator (data_samples/generator/occlusion_set.py):
train-split samples 0 .. N-1 only (the test split is never read), fixed seeds for the crops, augmentation
and initialisation, torch on the CPU with a fixed thread count. At the end it writes the weights and
patches WEIGHTS_SHA256 in occlusion_infer.py, so the stages using the network get a new code version.

    python tools/train_occlusion.py --cache /tmp/occ_cache [--samples 2000] [--steps 1500] [--threads 2]

The shipped weights are `--samples 2000 --steps 1500 --stop-after 1000` (seed 15, 2 threads): the learning
rate follows the 1500-step cosine schedule and training ends after step 1000 (about 47 min on 2 cores, plus
17 min generating the samples). CPU convolutions are not bitwise deterministic across machines or thread
counts, so a rerun reproduces the weights' quality (validation IoU), not their bytes.

Samples missing from the cache are generated first (tools/occlusion_data.py).
"""
from __future__ import annotations

import argparse
import math
import re
import sys
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ops.segmentation.network_input import colour_channels, paper_colour, resample, to_work, work_frame  # noqa: E402
from ops.segmentation.occlusion_net import (  # noqa: E402
    IN_CHANNELS,
    STRIDE,
    WEIGHTS_PATH,
    OcclusionUNet,
    save_weights,
)
from ops.segmentation.skeleton_guide import guide_channels  # noqa: E402
from ops.types import Skeleton  # noqa: E402
from tools.occlusion_data import ensure, load  # noqa: E402

SEED = 15
ZOOM_JITTER = 0.2  # log-uniform zoom factor in exp(+-this) around the working zoom
DROP_DEPTH = 0.15  # share of crops whose depth channels are zeroed (skeletons without z)


def prepare(sample: dict, rng: np.random.Generator, pad: int) -> dict:
    """A sample at its (jittered) working scale, padded by `pad` px: colour (3, h, w) float32 (paper = 0),
    guide (GUIDE_CHANNELS, h, w) int8 (x 127; computed once here, the crops only slice it), label (h, w) bool."""
    fg = sample["fg"] > 127
    frame = work_frame(fg, sample["pose"])
    frame.zoom *= float(np.exp(rng.uniform(-ZOOM_JITTER, ZOOM_JITTER)))
    x0, y0, x1, y1 = frame.box
    hw = frame.work_shape()
    img = sample["image"]
    colour = colour_channels(resample(np.ascontiguousarray(img[y0:y1, x0:x1]), hw), paper_colour(img))
    label = resample(sample["union"][y0:y1, x0:x1].astype(np.float32), hw) > 0.5
    pose = to_work(sample["pose"], frame)
    pose[:, :2] += pad
    shape = (hw[0] + 2 * pad, hw[1] + 2 * pad)
    skeleton = Skeleton(tuple(str(i) for i in range(len(pose))), sample["parents"])
    guide = np.round(guide_channels(pose, skeleton, shape) * 127).astype(np.int8)
    return {"colour": np.pad(colour, ((0, 0), (pad, pad), (pad, pad))).astype(np.float16), "guide": guide,
            "label": np.pad(label, pad)}


def crop(item: dict, rng: np.random.Generator, size: int) -> tuple[np.ndarray, np.ndarray]:
    """A random size x size training pair: (IN_CHANNELS, size, size) input and (1, size, size) label.

    The crop's centre lies inside the unpadded picture, at least size / 4 from the padded border."""
    label = item["label"]
    h, w = label.shape
    lo, hi_y, hi_x = size // 4, h - size // 4, w - size // 4
    ys, xs = np.nonzero(label)
    if len(ys) and rng.random() < 0.7:  # near an occluded pixel: positives are rare
        k = int(rng.integers(len(ys)))
        cy, cx = ys[k] + rng.integers(-size // 4, size // 4 + 1), xs[k] + rng.integers(-size // 4, size // 4 + 1)
    else:
        cy, cx = rng.integers(lo, max(hi_y, lo + 1)), rng.integers(lo, max(hi_x, lo + 1))
    cy, cx = int(np.clip(cy, lo, max(hi_y - 1, lo))), int(np.clip(cx, lo, max(hi_x - 1, lo)))
    y0, x0 = cy - size // 2, cx - size // 2
    x = np.zeros((IN_CHANNELS, size, size), np.float32)
    lab = np.zeros((1, size, size), np.float32)
    sy0, sx0, sy1, sx1 = max(y0, 0), max(x0, 0), min(y0 + size, h), min(x0 + size, w)
    inside = (slice(sy0 - y0, sy1 - y0), slice(sx0 - x0, sx1 - x0))
    x[(slice(0, 3), *inside)] = item["colour"][:, sy0:sy1, sx0:sx1]
    x[(slice(3, None), *inside)] = item["guide"][:, sy0:sy1, sx0:sx1] / 127.0
    lab[(0, *inside)] = label[sy0:sy1, sx0:sx1]
    if rng.random() < 0.5:  # mirror: the skeleton channels are mirror-symmetric
        x, lab = x[:, :, ::-1], lab[:, :, ::-1]
    x[:3] = x[rng.permutation(3)] * rng.uniform(0.7, 1.3)  # other palettes, paler or stronger drawings
    x[:3] += rng.normal(0, rng.uniform(0, 0.03), (3, size, size)).astype(np.float32)
    np.clip(x[:3], -1, 1, out=x[:3])
    if rng.random() < DROP_DEPTH:
        x[3 + 3: 3 + 5] = 0.0
    return np.ascontiguousarray(x), np.ascontiguousarray(lab)


def loss_fn(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Binary cross-entropy plus soft Dice (the Dice term keeps small joint overlaps from being ignored)."""
    bce = F.binary_cross_entropy_with_logits(logits, target)
    p = torch.sigmoid(logits)
    dice = 1 - (2 * (p * target).sum() + 1) / (p.sum() + target.sum() + 1)
    return bce + dice


def set_sha(digest: str) -> None:
    """Write the new weights' sha256 into ops/segmentation/occlusion_infer.py (which occlusion_net.py imports)."""
    path = ROOT / "ops" / "segmentation" / "occlusion_infer.py"
    text = path.read_text()
    text = re.sub(r'WEIGHTS_SHA256 = "[0-9a-f]{64}"', f'WEIGHTS_SHA256 = "{digest}"', text)
    path.write_text(text)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, required=True, help="sample cache (tools/occlusion_data.py)")
    ap.add_argument("--samples", type=int, default=2000, help="train samples 0 .. N-1")
    ap.add_argument("--steps", type=int, default=1500, help="length of the learning-rate schedule")
    ap.add_argument("--stop-after", type=int, default=None, help="end training after this many steps")
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--crop", type=int, default=96, help="training crop side, working pixels")
    ap.add_argument("--lr", type=float, default=3e-3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=WEIGHTS_PATH)
    ap.add_argument("--workers", type=int, default=1, help="processes generating missing samples")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    torch.manual_seed(SEED)
    rng = np.random.default_rng(SEED)
    t0 = time.perf_counter()
    paths = ensure(args.cache, "train", 0, args.samples, args.workers)
    items = [prepare(load(p), rng, args.crop // 4) for p in paths]
    print(f"{len(items)} samples prepared in {time.perf_counter() - t0:.0f} s", flush=True)
    net = OcclusionUNet().to(memory_format=torch.channels_last)  # ~30% faster convolutions on the CPU
    opt = torch.optim.AdamW(net.parameters(), lr=args.lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda s: min(1.0, (s + 1) / 100) * 0.5 * (1 + math.cos(math.pi * s / args.steps)))
    net.train()
    t0, running = time.perf_counter(), 0.0
    for step in range(min(args.steps, args.stop_after or args.steps)):
        batch = [crop(items[int(i)], rng, args.crop) for i in rng.integers(0, len(items), args.batch)]
        x = torch.from_numpy(np.stack([b[0] for b in batch])).contiguous(memory_format=torch.channels_last)
        y = torch.from_numpy(np.stack([b[1] for b in batch]))
        loss = loss_fn(net(x), y)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        running = 0.98 * running + 0.02 * loss.item() if step else loss.item()
        if step % 50 == 0 or step == args.steps - 1:
            print(f"step {step:5d}  loss {running:.4f}  lr {sched.get_last_lr()[0]:.2e}  "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
        if (step + 1) % 500 == 0:  # a checkpoint to look at while it trains
            save_weights(net, args.out.with_suffix(".partial.npz"))
    assert STRIDE == 16
    digest = save_weights(net, args.out)
    if args.out == WEIGHTS_PATH:
        set_sha(digest)
    print(f"weights {args.out} sha256 {digest} ({args.out.stat().st_size / 1e6:.2f} MB)")


if __name__ == "__main__":
    main()
