"""Placement benchmark: PCK of the humanoid template placed on drawings, against person-made and generated joints.

Real drawings: AnimatedDrawings' example characters (REALDEV_DIR = a folder holding char1 .. char6, each with
texture.png, mask.png and char_cfg.yaml; from facebookresearch/AnimatedDrawings, examples/characters, MIT).
Characters whose skeleton uses the humanoid's 16 joint names (char1-4) are placed with `humanoid`; char5 (a
bug with six arms) and char6 (a pig on four legs) have skeletons of their own names and are placed with their
own skeleton given as a skeleton file without positions (so the fit has no idea where anything goes but the
tree), reported apart. The placement reads only texture.png (the silhouette is found without the mask); the
mask gives the character's height that PCK is measured against. Also printed: the template's default
positions stretched over the true mask's bounding box, the baseline placement must beat.

Generated drawings: people and dolls of data_samples/generator in random poses (arms anywhere from hanging to
raised, legs apart or together), drawn in all five styles, joints mapped to the humanoid's names (torso = top
of the torso, neck = the head's centre, as AnimatedDrawings' annotators place them). The fit's weights were
tuned on TRAIN seeds in the ink, flat_colour and scan styles only; pencil and watercolour are the held-out
styles, and every reported generated number uses TEST seeds (never seen while tuning).

PCK@a: share of joints within a x the character's height (the bounding box of its mask) of the truth.
Run: .venv/bin/python benchmarks/bench_placement.py REALDEV_DIR [--n 40] [--split test] [--preview DIR]
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from data_samples.generator.characters import PERSON, human_pose, humanoid, person  # noqa: E402
from data_samples.generator.drawing import draw, make_look  # noqa: E402
from data_samples.generator.model import scaled  # noqa: E402
from data_samples.generator.styles import GIRL, KID  # noqa: E402
from ops.motion.animated_drawings import read_character  # noqa: E402
from ops.shotio.image_io import read_image  # noqa: E402
from ops.skeleton.placement import place_template  # noqa: E402
from ops.skeleton.silhouette import find_silhouette  # noqa: E402
from ops.skeleton.templates import HUMANOID, load_template  # noqa: E402

TUNED_STYLES = ("ink", "flat_colour", "scan")
HELD_OUT_STYLES = ("pencil", "watercolour")
TEST_SEED_BASE = 10_000_000
THRESHOLDS = (0.1, 0.15)


def pck(pred: np.ndarray, truth: np.ndarray, height: float) -> tuple[np.ndarray, np.ndarray]:
    """(J,) normalised errors and (len(THRESHOLDS),) PCK of (J, 2) predictions against (J, 2) truth."""
    err = np.linalg.norm(pred - truth, axis=1) / height
    return err, np.array([(err < a).mean() for a in THRESHOLDS])


def _box_baseline(mask: np.ndarray, template) -> np.ndarray:
    ys, xs = np.nonzero(mask)
    x0, x1, y0, y1 = xs.min(), xs.max(), ys.min(), ys.max()
    return np.c_[x0 + template.positions[:, 0] * (x1 - x0), y0 + template.positions[:, 1] * (y1 - y0)]


def _preview(img: np.ndarray, pred: np.ndarray, truth: np.ndarray, parents, joints, path: Path) -> None:
    """Drawing with the truth (green) and the placement (red: right side, blue: left, black: middle)."""
    vis = np.ascontiguousarray((np.clip(img[..., :3], 0, 1) * 255).astype(np.uint8)[..., ::-1])
    for j, p in enumerate(parents):
        if p < 0:
            continue
        cv2.line(vis, tuple(np.round(truth[p]).astype(int)), tuple(np.round(truth[j]).astype(int)), (0, 190, 0), 2)
        col = (0, 0, 230) if "right" in joints[j] else (230, 0, 0) if "left" in joints[j] else (0, 0, 0)
        cv2.line(vis, tuple(np.round(pred[p]).astype(int)), tuple(np.round(pred[j]).astype(int)), col, 2)
    cv2.imwrite(str(path), vis)


def real(realdev: Path, preview: Path | None) -> list[dict]:
    """Per character: PCK of the placement and of the box baseline."""
    rows = []
    for d in sorted(realdev.glob("char*")):
        if not (d / "char_cfg.yaml").is_file():
            continue
        ch = read_character(d / "char_cfg.yaml")
        if set(ch.joints) == set(HUMANOID.joints):
            template, kind = HUMANOID, "humanoid"
            truth = ch.pose[[ch.joints.index(n) for n in HUMANOID.joints]]
        else:
            with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
                json.dump({"joints": list(ch.joints), "parents": list(ch.parents)}, f)
            template, kind, truth = load_template(f.name), "own skeleton", ch.pose
        img = read_image(ch.texture)
        mask = cv2.imread(str(ch.mask), cv2.IMREAD_GRAYSCALE) > 127
        height = float(np.ptp(np.nonzero(mask)[0]) + 1)
        t0, c0 = time.perf_counter(), time.process_time()
        sil = find_silhouette(img)
        placed = place_template(sil.mask, template)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        err, score = pck(placed.positions, truth, height)
        _, base = pck(_box_baseline(mask, template), truth, height)
        rows.append({"name": d.name, "template": kind, "pck": score, "baseline": base, "seconds": wall, "cpu": cpu,
                     "worst": [template.joints[j] for j in np.argsort(-err)[:3] if err[j] >= 0.15]})
        if preview:
            _preview(img, placed.positions, truth, template.parents, template.joints, preview / f"real_{d.name}.png")
    return rows


# ----------------------------------------------------------------------------- generated humanoids

def _ad_truth(kind: str, pose: np.ndarray) -> np.ndarray:
    """(16, 2) humanoid joints of a generated pose (PERSON rig or the 15-joint doll), in HUMANOID order."""
    if kind == "person":
        i = {n: k for k, n in enumerate(PERSON.joints)}
        foot = lambda s: 0.5 * (pose[i[f"{s}_ankle"], :2] + pose[i[f"{s}_toe"], :2])  # noqa: E731
    else:
        names = ["pelvis", "neck", "head", "r_shoulder", "r_elbow", "r_hand", "l_shoulder", "l_elbow", "l_hand",
                 "r_hip", "r_knee", "r_foot", "l_hip", "l_knee", "l_foot"]
        i = {n: k for k, n in enumerate(names)}
        foot = lambda s: pose[i[f"{s}_foot"], :2]  # noqa: E731
    p = lambda n: pose[i[n], :2]  # noqa: E731
    rows = {"root": p("pelvis"), "hip": p("pelvis"), "torso": p("neck"), "neck": 0.5 * (p("neck") + p("head"))}
    for side, s in (("right", "r"), ("left", "l")):
        rows |= {f"{side}_shoulder": p(f"{s}_shoulder"), f"{side}_elbow": p(f"{s}_elbow"),
                 f"{side}_hand": p(f"{s}_hand"), f"{side}_hip": p(f"{s}_hip"), f"{side}_knee": p(f"{s}_knee"),
                 f"{side}_foot": foot(s)}
    return np.array([rows[n] for n in HUMANOID.joints])


def _angles(rng: np.random.Generator, person_rig: bool) -> dict[int, float]:
    """World bone angles (deg, 90 = down) of a random standing pose: arms hanging to raised, legs apart."""
    a = {}
    ra, rf, la, lf = (4, 5, 7, 8)
    a[ra] = rng.uniform(95, 245)
    a[rf] = a[ra] + rng.uniform(-50, 50)
    a[la] = rng.uniform(-65, 85)
    a[lf] = a[la] + rng.uniform(-50, 50)
    th, sh = ((10, 11), (14, 15)) if person_rig else ((10, 11), (13, 14))
    a[th[0]] = rng.uniform(88, 122)
    a[th[1]] = a[th[0]] + rng.uniform(-20, 10)
    a[sh[0]] = rng.uniform(58, 92)
    a[sh[1]] = a[sh[0]] + rng.uniform(-10, 20)
    a[1] = -90 + rng.normal(0, 4)
    a[2] = -90 + rng.normal(0, 8)
    return a


def generated(style: str, seed: int):
    """(image (H, W, 3) float32, truth (16, 2), height px) of one generated humanoid."""
    rng = np.random.default_rng([seed, 7])
    size = (int(rng.integers(192, 321)), int(rng.integers(192, 321)))
    if rng.random() < 0.7:
        kind = "person"
        char = person(seed, skirt=bool(rng.random() < 0.4), girth=rng.uniform(0.85, 1.2), sleeves=bool(rng.random() < 0.7))
        pose = PERSON.pose((0.0, 0.0), _angles(rng, True))
        palette = GIRL if rng.random() < 0.5 else KID
    else:
        kind = "doll"
        char = humanoid(seed)
        pose = human_pose((0.0, 0.0), _angles(rng, False))
        palette = KID
    lo, hi = pose[:, :2].min(0) - 22, pose[:, :2].max(0) + 22  # room for the parts around the joints
    k = rng.uniform(0.55, 0.8) * min(size[1] / (hi[0] - lo[0]), size[0] / (hi[1] - lo[1]))
    room = np.array([size[1], size[0]]) - k * (hi - lo)
    pose = pose.copy()
    pose[:, :2] = k * (pose[:, :2] - lo) + rng.uniform(0.3, 0.7, 2) * room
    drawing = draw(scaled(char, k), pose, size, make_look(style, palette, size, seed))
    union = drawing.union > 0.5
    height = float(np.ptp(np.nonzero(union)[0]) + 1)
    return drawing.rgb.astype(np.float32) / 255.0, _ad_truth(kind, pose), height


def generated_scores(styles: tuple[str, ...], n: int, split: str, preview: Path | None) -> dict[str, np.ndarray]:
    """Style -> (n, len(THRESHOLDS)) PCK per drawing."""
    out = {}
    for si, style in enumerate(styles):
        scores = []
        for i in range(n):
            seed = (TEST_SEED_BASE if split == "test" else 0) + 1000 * si + i
            img, truth, height = generated(style, seed)
            placed = place_template(find_silhouette(img).mask, HUMANOID)
            scores.append(pck(placed.positions, truth, height)[1])
            if preview and i < 3:
                _preview(img, placed.positions, truth, HUMANOID.parents, HUMANOID.joints,
                         preview / f"gen_{split}_{style}_{i}.png")
        out[style] = np.array(scores)
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("realdev", type=Path, nargs="?", help="folder with char1..char6 (AnimatedDrawings' examples)")
    ap.add_argument("--n", type=int, default=40, help="generated drawings per style")
    ap.add_argument("--split", choices=("train", "test"), default="test", help="seeds of the generated drawings")
    ap.add_argument("--styles", default=",".join(TUNED_STYLES + HELD_OUT_STYLES))
    ap.add_argument("--preview", type=Path, default=None, help="write overlays here")
    args = ap.parse_args(argv)
    if args.preview:
        args.preview.mkdir(parents=True, exist_ok=True)
    head = "  ".join(f"PCK@{a:g}" for a in THRESHOLDS)
    if args.realdev:
        rows = real(args.realdev, args.preview)
        print(f"real drawings ({args.realdev.name}): {head}   box baseline   cpu s   worst joints")
        for r in rows:
            print(f"  {r['name']:6s} {r['template']:13s} " + "  ".join(f"{v:7.3f}" for v in r["pck"])
                  + "   " + " / ".join(f"{v:.3f}" for v in r["baseline"]) + f"   {r['cpu']:5.2f}   {', '.join(r['worst'])}")
        for label, keep in (("humanoid (char1-4)", lambda r: r["template"] == "humanoid"), ("all", lambda r: True)):
            sel = [r for r in rows if keep(r)]
            if sel:
                mean = np.mean([r["pck"] for r in sel], axis=0)
                base = np.mean([r["baseline"] for r in sel], axis=0)
                print(f"  {label:20s} " + "  ".join(f"{v:7.3f}" for v in mean)
                      + "   " + " / ".join(f"{v:.3f}" for v in base))
    styles = tuple(s for s in args.styles.split(",") if s)
    if styles and args.n > 0:
        scores = generated_scores(styles, args.n, args.split, args.preview)
        print(f"generated humanoids, {args.split} seeds, {args.n} per style: {head}")
        for style, s in scores.items():
            tag = "held out" if style in HELD_OUT_STYLES else "tuned on (train seeds)"
            print(f"  {style:12s} " + "  ".join(f"{v:7.3f}" for v in s.mean(0)) + f"   {tag}")
        for label, group in (("tuned styles", TUNED_STYLES), ("held-out styles", HELD_OUT_STYLES)):
            sel = [scores[s] for s in group if s in scores]
            if sel:
                print(f"  {label:16s} " + "  ".join(f"{v:7.3f}" for v in np.concatenate(sel).mean(0)))


if __name__ == "__main__":
    main()
