"""Real drawings end to end: each photographed AnimatedDrawings character as a shot whose two keyframes
are the same drawing, run by the CLI as a user would.

The method must hold on real input: no crash, no traceback, and with nothing to move every output frame must
be the drawing again. Printed per character: exit status, seconds, the PSNR of every output frame composited
over the paper plate (ops/evaluation/plate.py) against the drawing, inside the person's mask and over the
whole image, and the warnings the stages logged (snapped joints, holes, dropped specks ...).
Data are read from the folder given as the first argument (AnimatedDrawings' examples/characters; never copied
into this repo); the shot folders go to a
temporary directory, or to --keep DIR to look at them.
Run: .venv/bin/python benchmarks/bench_realdev.py DATA_DIR [--only char1 ...] [--frames 3] [--keep DIR]
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.bench_masks import load_character  # noqa: E402
from ops.evaluation.plate import over, paper_plate  # noqa: E402
from ops.shotio.image_io import read_image, write_image  # noqa: E402
from resources.store import Store  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def make_shot(folder: Path, dst: Path, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Shot directory at dst from one character: key0 = key1 = its drawing, the same pose at t = 0 and 1."""
    drawing, mask, pose, skeleton = load_character(folder)
    dst.mkdir(parents=True, exist_ok=True)
    write_image(dst / "key0.png", drawing)
    write_image(dst / "key1.png", drawing)
    joints = [[float(x), float(y), float(z)] for x, y, z in pose]
    shot = {"format": "inbetween-shot/1", "keyframes": ["key0.png", "key1.png"],
            "skeleton": {"joints": list(skeleton.joints), "parents": skeleton.parents.tolist()},
            "poses": [{"t": 0.0, "joints": joints}, {"t": 1.0, "joints": joints}], "frames": frames,
            "t_junctions": [[], []]}
    (dst / "shot.json").write_text(json.dumps(shot, indent=1))
    return read_image(dst / "key0.png")[..., :3], mask


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - b) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(1.0 / mse)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", type=Path, help="folder of AnimatedDrawings characters (char1/char_cfg.yaml, ...)")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--keep", type=Path, default=None)
    args = ap.parse_args()
    chars = sorted(d for d in args.data.iterdir() if (d / "char_cfg.yaml").is_file() and (not args.only or d.name in args.only))
    work = args.keep or Path(tempfile.mkdtemp(prefix="realdev-"))
    print(f"{'character':10s} {'exit':>4s} {'s':>6s} {'min dB in mask':>15s} {'min dB image':>13s}  warnings")
    failures = 0
    for folder in chars:
        shot, home, out = work / "shots" / folder.name, work / "home", work / "out" / folder.name
        drawing, mask = make_shot(folder, shot, args.frames)
        env = {**os.environ, "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster")}
        start = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "assets.cli", "run", str(shot), "--out", str(out)], cwd=ROOT,
                              env=env, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            failures += 1
            print(f"{folder.name:10s} {proc.returncode:4d} {seconds:6.1f}  {proc.stderr.strip().splitlines()[-1:]}")
            continue
        store = Store(home / "storage")
        masks = [store.read(f"key{k}/masks", folder.name) for k in (0, 1)]
        plate = paper_plate([drawing, drawing], [m.coverage for m in masks], [m.paper for m in masks])
        frames = np.stack([read_image(p) for p in sorted((out / "frames").glob("*.png"))])
        composite = over(frames, plate)
        in_mask = min(psnr(f[mask], drawing[mask]) for f in composite)
        whole = min(psnr(f, drawing) for f in composite)
        warnings = sum(len(store.provenance(f"key{k}/{s}", folder.name)[1].get("warnings", []))
                       for k in (0, 1) for s in ("masks", "refined_masks", "template"))
        print(f"{folder.name:10s} {0:4d} {seconds:6.1f} {in_mask:15.1f} {whole:13.1f}  {warnings}")
    print(f"shots in {work}" if args.keep else "")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
