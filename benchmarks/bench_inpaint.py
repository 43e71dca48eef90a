"""Pocket inpainting against the hidden drawing: per sample shot and keyframe, the colour error of each method.

    inbetween eval data_samples --out DIR      # (or inbetween run) stores every stage under INBETWEEN_HOME
    python benchmarks/bench_inpaint.py --home INBETWEEN_HOME [--only flat_colour ...] [--out DIR]

For every keyframe lane of a sample shot stored under --home, the textured-template stage is repeated with
the stored template and refined masks, and the pixels it inpaints (pocket texture no keyframe shows) are
filled by every method (telea, ns, flat, auto) from the same context. The truth is what the generator draws
there once the parts in front are taken away: the keyframe's pose drawn again without the front bones of the
occlusion region the pixel lies in (data_samples/generator). Printed: per lane the inpainted pixels, the
holes and how many "auto" filled flat, and each method's mean CIE76 colour difference (ΔE) and PSNR over the
inpainted pixels that the truth shows as character. --out writes one preview per lane
(ops.appearance.inpaint_preview: each hole tinted by the method auto chose, stroke ends and continued
strokes, Telea's fill, auto's fill, and the truth).
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from data_samples.generator.model import Character, Part  # noqa: E402
from data_samples.generator.shots import SHOTS  # noqa: E402
from data_samples.generator.write import output_poses, shot_drawing, shot_look  # noqa: E402
from ops.appearance.flat_fill import FlatInpainter  # noqa: E402
from ops.appearance.inpaint import INPAINT_METHODS, make_inpainter  # noqa: E402
from ops.appearance.inpaint_preview import inpaint_preview  # noqa: E402
from ops.appearance.lane import texture_lane  # noqa: E402
from ops.appearance.strokes import lab  # noqa: E402
from ops.shotio.load import load_shot  # noqa: E402
from resources.store import Store  # noqa: E402


class Capture:
    """An inpainter that records what it is asked to fill (and fills with Telea, which the stage ignores here)."""

    def __init__(self):
        self.args = None

    def __call__(self, image, hole, coverage=None):
        self.args = (np.array(image, np.float32), np.array(hole, bool), None if coverage is None else np.array(coverage))
        return make_inpainter("telea")(image, hole)


def hidden_truth(name: str, k: int, fronts: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per occlusion region: (rgb (H, W, 3) float32, coverage (H, W) float32) of keyframe k drawn without the
    region's front bones (bone indices in Skeleton.bones order)."""
    spec = SHOTS[name]()
    _, poses = output_poses(spec)
    pose = poses[0] if k == 0 else poses[-1]
    look = shot_look(spec)
    out = []
    for front in fronts:
        parts = dict(spec.char.parts)
        for b in np.asarray(front, np.int64):
            parts[spec.char.bones[int(b)][1]] = Part("none", 0)
        char = Character(spec.char.joints, spec.char.parents, parts, spec.char.seed)
        drawing = shot_drawing(replace(spec, char=char), pose, look)
        out.append((drawing.rgb.astype(np.float32) / 255.0, np.asarray(drawing.union, np.float32)))
    return out


def scores(fill: np.ndarray, truth: np.ndarray, where: np.ndarray) -> tuple[float, float]:
    """(mean CIE76 ΔE, PSNR dB) of fill against truth, (H, W, 3) float32 RGB, over (H, W) bool `where`."""
    de = np.linalg.norm(lab(fill)[where] - lab(truth)[where], axis=1)
    mse = float(((fill[where] - truth[where]) ** 2).mean())
    return float(de.mean()), 10.0 * np.log10(1.0 / max(mse, 1e-12))


def lane(store: Store, shots: Path, name: str, k: int, out: Path | None) -> dict | None:
    """Every method's error on one lane's inpainted pixels; None when the lane inpaints nothing."""
    shot = load_shot(shots / name)
    template = store.read(f"key{k}/template", name)
    own, other = (store.read(f"key{j}/refined_masks", name) for j in (k, 1 - k))
    cap = Capture()
    texture_lane(template, own, other, shot.key_pose(k), shot.key_pose(1 - k), cap)
    if cap.args is None or not cap.args[1].any():
        return None
    context, hole, coverage = cap.args
    truth = np.zeros_like(context)
    shown = np.zeros(hole.shape, bool)
    for region, (rgb, cov) in zip(own.occlusion, hidden_truth(name, k, own.front_bones)):
        px = hole & region & ~shown
        truth[px] = rgb[px]
        shown |= px & (cov > 0.5)
    row = {"shot": name, "key": k, "pixels": int(hole.sum()), "scored": int(shown.sum())}
    fills = {}
    for method in INPAINT_METHODS:
        fills[method] = make_inpainter(method)(context, hole, coverage=coverage)
        row[method] = scores(fills[method], truth, shown) if shown.any() else (np.nan, np.nan)
    _, plans = FlatInpainter("auto").fill(context, hole, coverage)
    row["holes"], row["flat_holes"] = len(plans), sum(p.method == "flat" for p in plans)
    row["flat_px"] = sum(len(p.pixels) for p in plans if p.method == "flat")
    if out is not None:
        shown_truth = np.where(shown[..., None], truth, 0.35 * context + 0.65)  # unscored pixels washed out
        panels = inpaint_preview(context, hole, plans, fills["auto"], fills["telea"], shown_truth)
        out.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(out / f"{name}_key{k}.png"), np.round(np.clip(panels[..., ::-1], 0, 1) * 255).astype(np.uint8))
    return row


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--home", type=Path, required=True, help="INBETWEEN_HOME holding the shots' stored stages")
    ap.add_argument("--shots", type=Path, default=ROOT / "data_samples", help="the sample shots' directory")
    ap.add_argument("--only", nargs="*", default=None, choices=list(SHOTS))
    ap.add_argument("--out", type=Path, default=None, help="write one preview per lane here")
    args = ap.parse_args(argv)
    store = Store(args.home / "storage")
    rows = []
    for name in args.only or list(SHOTS):
        if not store.path("key0/template", name).exists():
            print(f"{name}: no stored template under {args.home}; run the shot first")
            continue
        for k in (0, 1):
            row = lane(store, args.shots, name, k, args.out)
            if row is not None:
                rows.append(row)
    head = "shot          key  pixels  scored  holes  flat  " + "  ".join(f"{m:>12}" for m in INPAINT_METHODS)
    print(head + "\n" + "-" * len(head) + "   (mean ΔE / PSNR dB over the scored pixels)")
    for r in rows:
        cells = "  ".join(f"{r[m][0]:5.1f} / {r[m][1]:4.1f}" for m in INPAINT_METHODS)
        print(f"{r['shot']:<13} {r['key']:>3}  {r['pixels']:>6}  {r['scored']:>6}  {r['holes']:>5}  "
              f"{r['flat_holes']:>4}  {cells}")
    scored = [r for r in rows if r["scored"]]
    if scored:
        n = np.array([r["scored"] for r in scored], float)
        cells = "  ".join(f"{np.average([r[m][0] for r in scored], weights=n):5.1f} /  -  " for m in INPAINT_METHODS)
        print(f"{'all (pixel-weighted ΔE)':<31}{int(n.sum()):>6}{'':>14}{cells}")


if __name__ == "__main__":
    main()
