"""Held-out in-betweening shots: two-key shots drawn by the 3D generator, which no tuning of the method ever saw.

    python benchmarks/heldout_shots.py OUT_DIR [--count 8] [--size 256] [--bvh BVH_DIR]
    python benchmarks/heldout_shots.py OUT_DIR --set redrawn [--count 9] [--size 256] [--amount A]
    python benchmarks/heldout_shots.py OUT_DIR [--set redrawn] --true-annotation   # the masks a person would paint
    python -m assets.cli eval OUT_DIR --out EVAL_DIR          # then score ours, RIFE-direct and the rest

Every tuning of the pipeline used the 2D generator's sample shots (data_samples/). These come from the other,
independent generator (data_samples/generator/shots3d.py: 3D bodies ray cast and drawn in a random style)
with seeds from its test split, so neither the occlusion network's training nor any tuning drew one of them;
the default eight mix every body family and style, three hold the network's held-out creature body or crayon
style, and in four a limb comes to cross the body between the keys (checked on the depth buffer). One shot:
one body, camera and look, SHOT_FRAMES = 9 frames along a motion (procedural, or people along a clip of
BVH_DIR), key0 / key1 the first and last, gt/ all nine; shot.json gives every frame's projected
AnimatedDrawings-style skeleton (x, y px, depth z, larger = farther) and no T-junctions (the tool proposes
them, as a user's default is). Each shot is loaded back with ops.shotio.load.load_shot, and a contact sheet
OUT_DIR/previews/<shot>.png shows its frames with the skeleton drawn over them (keys framed red).

--set redrawn writes the held-out redrawn set instead (data_samples/generator/redrawn3d.py): 11 shots from its
9 plan entries (two of them also give a rigid twin: the same shot with amount 0), whose keys are redrawn
(per part +-20 % aspect, another outline, another shaky hand; the in-betweens interpolate them) in side-view
walks with overlapping legs, arms over a round belly and arms folded over the chest; each shot's heldout.json
says what it holds (kind, redraw amount, style, family, twins) and what the generator measured of its
promises (checks). --amount A redraws every redrawn shot by A instead of its plan's amount (0: all rigid).

--true-annotation writes the same shots annotated as a person who knew the drawing would annotate them: one
painted occlusion mask per pair of overlapping bones that share no joint (the generator's depth buffer says
which pixels, and the bone in front), and the T-junctions where the back bone's outline meets the front one
(shots3d.write_true_annotation; heldout.json lists the regions under "true_annotation"). Scored beside the plain
set, it says how much of a shot's error the occlusion reading causes and how much the template and lanes do.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from data_samples.generator.redrawn3d import REDRAWN_PLAN, make_redrawn3d  # noqa: E402
from data_samples.generator.shots3d import (  # noqa: E402
    PLAN,
    Shot3D,
    make_shot3d,
    write_shot3d,
    write_true_annotation,
)
from ops.shotio.load import ground_truth_files, load_shot  # noqa: E402


def check_shot(d: Path) -> None:
    """Load the written shot as the pipeline does; ValueError naming the shot on anything inconsistent."""
    shot = load_shot(d)
    data = json.loads((d / "shot.json").read_text())
    given = np.array([p["joints"] for p in data["poses"]], np.float64)
    problems = []
    if len(shot.times) != data["frames"] or len(ground_truth_files(shot.ground_truth)) != data["frames"]:
        problems.append("output frames, poses and gt/ frames disagree")
    if not np.allclose(shot.poses, given, atol=1e-6):
        problems.append("the loader's poses are not the written ones")
    gt = ground_truth_files(shot.ground_truth)
    for k, f in ((0, gt[0]), (1, gt[-1])):
        if (d / f"key{k}.png").read_bytes() != f.read_bytes():
            problems.append(f"key{k}.png differs from {f.name}")
    if problems:
        raise ValueError(f"{d}: " + "; ".join(problems))


def contact_sheet(d: Path, out: Path) -> Path:
    """out/<shot>.png: every gt frame with the shot's skeleton drawn over it (joints nearer = brighter), the keys
    framed red, the shot's name and look above."""
    data = json.loads((d / "shot.json").read_text())
    meta = json.loads((d / "heldout.json").read_text())
    parents = data["skeleton"]["parents"]
    tiles = []
    for i, f in enumerate(ground_truth_files(d / "gt")):
        img = cv2.imread(str(f), cv2.IMREAD_COLOR)
        over = img.copy()
        pose = np.array(data["poses"][i]["joints"])
        for c, p in enumerate(parents):
            if p >= 0:
                cv2.line(over, tuple(int(round(v)) for v in pose[p, :2]), tuple(int(round(v)) for v in pose[c, :2]),
                         (200, 90, 0), 1, cv2.LINE_AA)
        z = pose[:, 2]
        near = (z.max() - z) / max(float(np.ptp(z)), 1e-6)
        for (x, y, _), a in zip(pose, near):
            cv2.circle(over, (int(round(x)), int(round(y))), 2, (0, int(80 + 170 * a), 0), -1, cv2.LINE_AA)
        pair = np.concatenate([img, over], axis=0)
        if i in (0, len(data["poses"]) - 1):
            cv2.rectangle(pair, (0, 0), (pair.shape[1] - 1, pair.shape[0] - 1), (0, 0, 220), 2)
        cv2.putText(pair, f"{i}", (4, 14), cv2.FONT_HERSHEY_PLAIN, 1.0, (40, 40, 200), 1, cv2.LINE_AA)
        tiles.append(pair)
    sheet = np.concatenate(tiles, axis=1)
    head = np.full((22, sheet.shape[1], 3), 255, np.uint8)
    text = f"{d.name}: {meta['view']} view, motion {meta['motion']}, held out: {meta['held_out_of_occlusion_training']}"
    if "redraw" in meta:
        text += f", redrawn by {meta['redraw']}"
    cv2.putText(head, text, (4, 15), cv2.FONT_HERSHEY_PLAIN, 1.0, (0, 0, 0), 1, cv2.LINE_AA)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{d.name}.png"
    cv2.imwrite(str(path), np.concatenate([head, sheet], axis=0), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return path


def _shots(args: argparse.Namespace):
    """The set's shots, one plan entry at a time (a redrawn entry may give a rigid twin too)."""
    size = (args.size, args.size)
    if args.set == "default":
        for i in range(args.count):
            yield [make_shot3d(i, size, args.bvh)]
        return
    first = 0
    for entry in range(args.count):
        amounts = None
        if args.amount is not None:
            amounts = tuple(args.amount if a else 0.0 for a in REDRAWN_PLAN[entry % len(REDRAWN_PLAN)][3])
        shots = make_redrawn3d(entry, size, first, amounts=amounts)
        first += len(shots)
        yield shots


def _describe(shot: Shot3D, meta: dict) -> str:
    """One line of what the shot holds."""
    if shot.extra.get("set") == "redrawn":
        return f"{shot.view:14s} redraw {shot.extra['redraw']:.1f} checks {json.dumps(shot.extra['checks'])}"
    return f"{shot.view:18s} {shot.motion:24s} held out {meta['held_out_of_occlusion_training']}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="folder to write the shots into (one sub-folder each)")
    ap.add_argument("--set", choices=("default", "redrawn"), default="default",
                    help="default: the eight held-out shots; redrawn: keys redrawn, overlapping legs, folded arms")
    ap.add_argument("--count", type=int, default=None,
                    help=f"number of plan entries K (default: all, {len(PLAN)} / {len(REDRAWN_PLAN)}; the plan cycles)")
    ap.add_argument("--size", type=int, default=256, help="drawing width and height, px (at most 256)")
    ap.add_argument("--bvh", type=Path, default=None, help="folder of .bvh clips that move the people (default set)")
    ap.add_argument("--amount", type=float, default=None,
                    help="redrawn set: redraw every redrawn shot by this amount instead of its plan's (0: rigid)")
    ap.add_argument("--true-annotation", action="store_true",
                    help="paint each key's true occlusion regions and T-junctions into its shot.json (a control)")
    args = ap.parse_args(argv)
    if args.count is None:
        args.count = len(PLAN) if args.set == "default" else len(REDRAWN_PLAN)
    if args.set == "redrawn" and args.bvh is not None:
        ap.error("--bvh: the redrawn set's motions are procedural; leave --bvh out")
    if args.set == "default" and args.amount is not None:
        ap.error("--amount: only the redrawn set is redrawn; add --set redrawn")
    if args.amount is not None and not 0 <= args.amount <= 2:
        ap.error(f"--amount {args.amount}: give 0 to 2")
    if not 64 <= args.size <= 256:
        ap.error(f"--size {args.size}: give 64 to 256 px")
    if args.count < 1:
        ap.error(f"--count {args.count}: give at least one shot")
    if args.bvh is not None and not sorted(args.bvh.glob("*.bvh")):
        ap.error(f"--bvh {args.bvh}: no .bvh files there; give a folder of BVH clips or leave --bvh out")
    records = []
    t0 = time.perf_counter()
    for shots in _shots(args):
        for shot in shots:
            d = write_shot3d(shot, args.out)
            if args.true_annotation:
                meta = json.loads((d / "heldout.json").read_text())
                meta["true_annotation"] = write_true_annotation(shot, d)
                (d / "heldout.json").write_text(json.dumps(meta, indent=1) + "\n")
            check_shot(d)
            sheet = contact_sheet(d, args.out / "previews")
            meta = json.loads((d / "heldout.json").read_text())
            records.append(meta | {"shot": d.name})
            print(f"{d.name:40s} {_describe(shot, meta)} ({time.perf_counter() - t0:.1f} s) -> "
                  f"{sheet.relative_to(args.out)}", flush=True)
        t0 = time.perf_counter()
    (args.out / "previews" / "manifest.json").write_text(json.dumps(records, indent=1) + "\n")
    print(f"{len(records)} shots written and loaded back; score them with: python -m assets.cli eval {args.out} "
          f"--out EVAL_DIR")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
