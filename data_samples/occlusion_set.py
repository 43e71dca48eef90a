"""Command line of the generated occlusion dataset (issue 15); the code is data_samples/generator/occlusion_set.py.

Usage: python data_samples/occlusion_set.py --split test --n 60 --out DIR [--start 0] [--workers 2]

Writes one folder per sample: image.png, skeleton.json (joints, parents, pose), fg.png, occ_union.png,
occ_{i}.png and meta.json (class, style, per mask the front and back part). From Python, without files:
`from data_samples.generator.occlusion_set import make_sample, samples`.
"""
from __future__ import annotations

import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import ops  # noqa: E402, F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
from data_samples.generator.occlusion_set import main  # noqa: E402

if __name__ == "__main__":
    main()
