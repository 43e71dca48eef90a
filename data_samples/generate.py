"""Synthesize the sample shots: layered 2D characters drawn in ink, watercolour, flat colour, pencil or as a scan.

Usage: python data_samples/generate.py [--out data_samples] [--only NAME ...]

Each character is a skeleton whose bones carry a body part (capsule, ellipse, tapered limb, skirt...) painted
back to front by depth (z, larger = farther). Every shot directory follows docs/shot-format.md
("inbetween-shot/1"; the sequences and one-drawing shots of sequences.py "inbetween-shot/2") and carries the ground truth used by evaluation: gt/0000.png ... (one per output time),
gt_fg/key{k}.png (coverage), gt_occ/ (occlusion masks; see data_samples/README.md for which file means what).

Deterministic: every random choice comes from numpy generators seeded per shot and per bone, and the drawing
is plain OpenCV rasterization. The code lives in data_samples/generator/; this file is its command line.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import ops  # noqa: E402, F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
from data_samples.generator.characters import human_pose, humanoid, tentacle  # noqa: E402
from data_samples.generator.geometry import part_outline, polygon_crossings, signed_distance  # noqa: E402
from data_samples.generator.legacy import render  # noqa: E402
from data_samples.generator.model import Character, Part, make_texture, scaled  # noqa: E402
from data_samples.generator.occlusion import Occlusion, occlusion_pairs, occlusions, t_junctions  # noqa: E402
from data_samples.generator.order import draw_order  # noqa: E402
from data_samples.generator.poses import forward, interpolate_pose, quantize  # noqa: E402
from data_samples.generator.sequences import SEQUENCES, write_sequence  # noqa: E402
from data_samples.generator.shots import SHOTS, ShotSpec  # noqa: E402
from data_samples.generator.write import (  # noqa: E402
    FRAMES,
    contact_sheet,
    generate,
    output_poses,
    shot_drawing,
    shot_look,
    write_shot,
)

__all__ = ["FRAMES", "SHOTS", "Character", "Occlusion", "Part", "ShotSpec", "draw_order", "forward", "generate",
           "human_pose", "humanoid", "interpolate_pose", "make_texture", "occlusion_pairs", "occlusions",
           "output_poses", "part_outline", "polygon_crossings", "quantize", "render", "scaled", "shot_drawing",
           "shot_look", "signed_distance", "t_junctions", "tentacle", "write_shot", "contact_sheet"]


def main(argv: list[str] | None = None) -> None:
    """Command line: python data_samples/generate.py [--out DIR] [--only NAME ...]."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    ap.add_argument("--only", nargs="*", choices=[*SHOTS, *SEQUENCES], default=None)
    args = ap.parse_args(argv)
    v1 = None if args.only is None else [n for n in args.only if n in SHOTS]
    v2 = list(SEQUENCES) if args.only is None else [n for n in args.only if n in SEQUENCES]
    written = generate(args.out, v1) if v1 is None or v1 else []
    for d in [*written, *(write_sequence(SEQUENCES[n](), args.out) for n in v2)]:
        data = json.loads((d / "shot.json").read_text())
        print(f"{d}: t_junctions per key {[len(t) for t in data['t_junctions']]}")
    sheet = contact_sheet(args.out)
    if sheet is not None:
        print(f"{sheet}: keyframes of the issue 8 shots")


if __name__ == "__main__":
    main()
