"""Train the occlusion network (ops/segmentation/occlusion_net.py) on generated characters, reproducibly.

Reproduces ops/segmentation/occlusion_unet.npz from the two generators: the 3D one (data_samples/generator/
occlusion3d.py: posed 3D bodies drawn with a depth buffer, people posed by BVH clips from --bvh) and the 2D one
(data_samples/generator/occlusion_set.py). Train-split samples only (the test splits are never read for
training), and of the 3D generator only the body and style families that are not held out (creature bodies
and crayon drawings never appear). Fixed seeds for the crops, augmentation and initialisation, torch on the CPU
with a fixed thread count. At the end it writes the weights, patches WEIGHTS_SHA256 in occlusion_infer.py (so
the stages using the network get a new code version) and prints the validation IoU on data never trained on
(tools/occlusion_eval.py: the 2D test split, the 3D test split's seen families and its two held-out families).

    python tools/train_occlusion.py --cache CACHE_DIR --bvh BVH_DIR [--samples3d 3000] [--samples 1200]
        [--steps 2500] [--threads 2]

BVH_DIR: the AnimatedDrawings clips (examples/bvh of facebookresearch/AnimatedDrawings, MIT). The shipped
weights' exact command and figures are in docs/weights.md. CPU convolutions are not bitwise deterministic
across machines or thread counts, so a rerun reproduces the weights' quality (validation IoU), not their bytes.

Samples missing from the cache are generated first (tools/occlusion_data.py).
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
from tools.occlusion_eval import network_regions, use_weights, validate  # noqa: E402

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
    ap.add_argument("--bvh", type=Path, default=None, help="folder of .bvh clips that pose the 3D generator's people")
    ap.add_argument("--samples3d", type=int, default=3000, help="3D train samples (the first N trained-on indices)")
    ap.add_argument("--samples", type=int, default=1200, help="2D train samples 0 .. N-1")
    ap.add_argument("--share3d", type=float, default=0.7, help="share of each batch's crops from the 3D samples")
    ap.add_argument("--steps", type=int, default=2500, help="length of the learning-rate schedule")
    ap.add_argument("--stop-after", type=int, default=None, help="end training after this many steps")
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--crop", type=int, default=96, help="training crop side, working pixels")
    ap.add_argument("--lr", type=float, default=3e-3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=WEIGHTS_PATH)
    ap.add_argument("--workers", type=int, default=1, help="processes generating missing samples")
    ap.add_argument("--val-n", type=int, default=60, help="samples per validation set")
    ap.add_argument("--validate-only", action="store_true", help="only print the validation of --out")
    args = ap.parse_args(argv)
    bvh = str(args.bvh) if args.bvh else None
    if not args.validate_only:
        train(args, bvh)
    digest = use_weights(args.out)
    print(f"validation of {args.out} (sha256 {digest}): IoU of the network's regions, true foreground")
    validate(args.val_n, args.cache, bvh, {"network": network_regions}, args.workers)


def train(args: argparse.Namespace, bvh: str | None) -> None:
    """Train from scratch on the cached samples and write the weights (and their sha256, for the shipped file)."""
    torch.set_num_threads(args.threads)
    torch.manual_seed(SEED)
    rng = np.random.default_rng(SEED)
    t0 = time.perf_counter()
    paths3d = ensure(args.cache, "train", 0, args.samples3d, args.workers, "3d", bvh) if args.samples3d else []
    paths2d = ensure(args.cache, "train", 0, args.samples, args.workers) if args.samples else []
    items3d = [prepare(load(p), rng, args.crop // 4) for p in paths3d]
    items2d = [prepare(load(p), rng, args.crop // 4) for p in paths2d]
    print(f"{len(items3d)} 3D and {len(items2d)} 2D samples prepared in {time.perf_counter() - t0:.0f} s", flush=True)
    pools = [(items3d, args.share3d), (items2d, 1 - args.share3d)]
    pools = [(items, share) for items, share in pools if items and share > 0]
    shares = np.array([share for _, share in pools]) / sum(share for _, share in pools)
    net = OcclusionUNet().to(memory_format=torch.channels_last)  # ~30% faster convolutions on the CPU
    opt = torch.optim.AdamW(net.parameters(), lr=args.lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda s: min(1.0, (s + 1) / 100) * 0.5 * (1 + math.cos(math.pi * s / args.steps)))
    net.train()
    t0, running = time.perf_counter(), 0.0
    for step in range(min(args.steps, args.stop_after or args.steps)):
        batch = []
        for _ in range(args.batch):
            items = pools[int(rng.choice(len(pools), p=shares))][0]
            batch.append(crop(items[int(rng.integers(len(items)))], rng, args.crop))
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
    print(f"weights {args.out} sha256 {digest} ({args.out.stat().st_size / 1e6:.2f} MB)", flush=True)


if __name__ == "__main__":
    main()
