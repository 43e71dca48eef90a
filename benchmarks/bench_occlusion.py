"""Occlusion masks: IoU of the drawing predictor, the hybrid and the skeleton rule on data never trained on, the
pair regions' fronts, timing, real drawings, end to end.

    python benchmarks/bench_occlusion.py --cache CACHE_DIR --bvh BVH_DIR      # every set, 60 samples each
    python benchmarks/bench_occlusion.py --cache C --n 100 --sets "2d test"         # one set, more samples
    python benchmarks/bench_occlusion.py --real REALDEV_DIR                          # + overlays of real drawings
    python benchmarks/bench_occlusion.py --e2e --shots arm_cross legs_cross         # + end to end (slow: minutes a shot)

The validation sets (tools/occlusion_eval.py) come from the generators' test splits, which training and tuning
never see: the 2D generator's (today's benchmark), and the 3D generator's seen families and its two held-out
families (a body family and a style family no training sample has). BVH_DIR: the folder of .bvh clips the
training data had (the AnimatedDrawings clips); REALDEV_DIR: a folder holding AnimatedDrawings' example
characters as animated_drawings/char1 ... (char_cfg.yaml, texture.png, mask.png; MIT), kept out of the
repository.

IoU is per keyframe with an occlusion: the union of the predicted regions against the union of the ground
truth (every overlap of a nearer part over a farther one, joint overlaps included). Every predictor runs twice:
given the true foreground (so the numbers do not depend on the foreground segmentation) and given the
foreground that ops.segmentation.foreground predicts. `drawing` is the network's pair regions
(occlusion_drawing.predict_occlusion), `hybrid` the skeleton rule's regions cut to the network's marks or the
strokes (shape_by_drawing), `skeleton` the rule alone. Fronts: for every true overlap of two bones that share
no joint (40 px or more), the drawing predictor's pair region over it: is its front bone the true one, read off
the drawing or from z, and how often the drawing spoke.

End to end (--e2e): each shot runs through the whole graph with Settings(occlusion=m) for every predictor m in
a private INBETWEEN_HOME, then its evaluation group; printed are the mean PSNR over the interior frames of ours
with each predictor and of RIFE applied directly to the keys.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import os
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ops.segmentation.bones import bone_depths  # noqa: E402
from ops.segmentation.contacts import scale_of  # noqa: E402
from ops.segmentation.foreground import segment_foreground  # noqa: E402
from ops.segmentation.occlusion import predict_occlusion as skeleton_occlusion  # noqa: E402
from ops.segmentation.occlusion_drawing import occlusion_marks, shape_by_drawing  # noqa: E402
from ops.segmentation.occlusion_drawing import predict_occlusion as drawing_occlusion  # noqa: E402
from ops.segmentation.occlusion_pairs import outline_contrast, pair_components, read_front  # noqa: E402
from ops.settings import Settings  # noqa: E402
from ops.types import Skeleton  # noqa: E402
from tools.occlusion_eval import SET_NOTES, SETS, iou, load_set, union_of, use_weights  # noqa: E402

OCCLUSION_SHOTS = ("arm_cross", "legs_cross", "tail", "two_poses", "watercolour", "flat_colour", "scan_jpeg",
                   "hand_on_hip", "lamp", "curled_tail")  # every sample shot with an occlusion in a keyframe
METHODS = ("drawing", "hybrid", "skeleton")
COLUMNS = [f"{m}|{f}" for f in ("gt fg", "pred fg", "apart") for m in METHODS]


def predict(method: str, image: np.ndarray, fg: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
            joint_overlaps: bool = True) -> np.ndarray:
    """(H, W) bool union of `method`'s regions on a (H, W, 3) uint8 drawing (joint_overlaps False: the drawing
    predictor as the masks stage calls it; the other two leave joints out anyway)."""
    if method == "drawing":
        regions = drawing_occlusion(image, fg, pose, skeleton, joint_overlaps=joint_overlaps)[0]
    else:
        regions, fronts, _ = skeleton_occlusion(fg, pose, skeleton)
        if method == "hybrid":
            regions = shape_by_drawing(regions, fronts, image, fg, pose, skeleton)
    return union_of(regions, fg.shape)


def score(image: np.ndarray, truth: np.ndarray, true_fg: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
          apart: np.ndarray | None = None) -> dict[str, float]:
    """IoU of each method given the true and the predicted foreground: {'drawing|gt fg': ..., ...}; with `apart`
    (the truth's overlaps of bones that share no joint) also 'm|apart', each method as the masks stage runs it
    (no joint overlaps) against that, given the true foreground."""
    pred_fg = segment_foreground(image.astype(np.float32) / 255.0, pose, skeleton).mask
    out = {}
    for fg_name, fg in (("gt fg", true_fg), ("pred fg", pred_fg)):
        for m in METHODS:
            out[f"{m}|{fg_name}"] = iou(predict(m, image, fg, pose, skeleton), truth)
    if apart is not None and apart.any():
        for m in METHODS:
            out[f"{m}|apart"] = iou(predict(m, image, true_fg, pose, skeleton, joint_overlaps=False), apart)
    return out


def score_sets(names: list[str], n: int, cache: Path, bvh: str | None, rows: bool) -> dict[str, list]:
    """Score n samples of each validation set; a row per keyframe when `rows`; returns the scores by column."""
    table = defaultdict(list)
    for name in names:
        for d in load_set(name, n, cache, bvh):
            if not d["union"].any():
                continue
            apart = union_of([m for m, p in zip(d["pair_masks"], d["pairs"] or []) if not p["adjacent"]],
                             d["union"].shape)
            sc = score(d["image"], d["union"], d["fg"] > 127, d["pose"], d["skeleton"], apart)
            sc = {k: sc.get(k, np.nan) for k in COLUMNS}  # a keyframe with no apart overlap has no 'apart' score
            table["set"].append(name)
            table["label"].append(d["label"])
            table["style"].append(d["style"])
            table["view"].append(d["view"] or "-")
            for k, v in sc.items():
                table[k].append(v)
            if rows:
                print(f"{name:18s} {d['label']:20s} {d['style']:12s} " + "  ".join(f"{v:.3f}" for v in sc.values()),
                      flush=True)
    return table


def front_accuracy(names: list[str], n: int, cache: Path, bvh: str | None) -> None:
    """Per set: of the true overlaps of two bones that share no joint (>= 40 px), how often the drawing
    predictor's region for that bone pair exists and has the true front; how often the drawing spoke, how often
    it was right then, and how often z alone is right on the same regions (true foreground)."""
    print("\nFronts of the pair regions (true overlaps of bones that share no joint, >= 40 px; true foreground)\n")
    print("| set | pairs | region found | front right | drawing spoke | drawing right | z alone right |")
    print("|---|---|---|---|---|---|---|")
    for name in names:
        c = defaultdict(int)
        for d in load_set(name, n, cache, bvh):
            sk, fg, pose = d["skeleton"], d["fg"] > 127, d["pose"]
            truth = [(m, p) for m, p in zip(d["pair_masks"], d["pairs"] or []) if not p["adjacent"] and p["pixels"] >= 40]
            if not truth:
                continue
            mask, radii, _ = occlusion_marks(d["image"], fg, pose, sk)
            contrast = outline_contrast(d["image"], scale_of(fg))
            found = {(a, b): (region, read_front(region, a, b, contrast, fg, pose, sk, radii).front)
                     for a, b, region in pair_components(mask, pose, sk, radii)}
            depth = bone_depths(pose, sk)
            for m, p in truth:
                c["pairs"] += 1
                key = tuple(sorted((p["front_bone"], p["back_bone"])))
                if key not in found or (found[key][0] & m).sum() < 0.3 * m.sum():
                    continue
                seen = found[key][1]
                by_z = min(key, key=lambda b: depth[b])
                c["found"] += 1
                c["right"] += int((seen if seen >= 0 else by_z) == p["front_bone"])
                c["z right"] += int(by_z == p["front_bone"])
                c["spoke"] += int(seen >= 0)
                c["spoke right"] += int(seen == p["front_bone"])
        f = max(c["found"], 1)
        print(f"| {name} {SET_NOTES.get(name, '')} | {c['pairs']} | {c['found'] / max(c['pairs'], 1):.3f} | "
              f"{c['right'] / f:.3f} | {c['spoke'] / f:.3f} | {c['spoke right'] / max(c['spoke'], 1):.3f} | "
              f"{c['z right'] / f:.3f} |")


def sample_shots() -> dict[str, list]:
    """Score the keyframes of data_samples/ that have an occlusion (gt_occ/key{k}_union.png)."""
    from ops.shotio.image_io import read_image
    from ops.shotio.load import load_shot

    table = defaultdict(list)
    for name in OCCLUSION_SHOTS:
        d = ROOT / "data_samples" / name
        shot = load_shot(d)
        for k in (0, 1):
            truth = cv2.imread(str(d / "gt_occ" / f"key{k}_union.png"), cv2.IMREAD_GRAYSCALE) > 127
            if not truth.any():
                continue
            image = np.round(read_image(shot.keyframes[k])[..., :3] * 255).astype(np.uint8)
            true_fg = cv2.imread(str(d / "gt_fg" / f"key{k}.png"), cv2.IMREAD_GRAYSCALE) > 127
            sc = score(image, truth, true_fg, shot.key_pose(k), shot.skeleton)
            table["label"].append(f"{name} key{k}")
            for key, v in sc.items():
                table[key].append(v)
    return table


def print_summary(table: dict[str, list], by: str, title: str, within: str | None = None) -> None:
    """Mean IoU per method, overall and per value of column `by` (only rows whose `set` is `within`)."""
    cols = [c for c in COLUMNS if c in table]
    keep = [i for i in range(len(table[by])) if within is None or table["set"][i] == within]
    if not keep:
        return
    print(f"\n{title}\n")
    print(f"| {by} | n | " + " | ".join(cols) + " |")
    print("|---|---|" + "---|" * len(cols))
    groups = sorted({table[by][i] for i in keep}, key=lambda g: (SETS.index(g) if g in SETS else 0, g))
    for g in groups + ["**mean**"]:
        idx = [i for i in keep if table[by][i] == g or g == "**mean**"]
        vals = [float(np.nanmean([table[c][i] for i in idx])) for c in cols]
        print(f"| {g} | {len(idx)} | " + " | ".join(f"{v:.3f}" for v in vals) + " |")


def timing(repeats: int = 5) -> None:
    """Seconds of the drawing predictor on a 512 px keyframe (a test sample scaled up), and of the skeleton rule."""
    from data_samples.generator.occlusion_set import make_sample

    s = make_sample("test", 3)
    f = 512.0 / max(s.image.shape[:2])
    size = (int(round(s.image.shape[1] * f)), int(round(s.image.shape[0] * f)))
    image = cv2.resize(s.image, size, interpolation=cv2.INTER_LINEAR)
    fg = cv2.resize(s.foreground, size, interpolation=cv2.INTER_LINEAR) > 0.5
    pose = s.pose.copy()
    pose[:, :2] = (pose[:, :2] + 0.5) * f - 0.5
    skeleton = Skeleton(tuple(s.joints), np.asarray(s.parents, np.int64))
    drawing_occlusion(image, fg, pose, skeleton)  # loads the weights once
    for m in METHODS:
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            predict(m, image, fg, pose, skeleton)
            times.append(time.perf_counter() - t0)
        print(f"{m:9s} predictor on a {image.shape[1]}x{image.shape[0]} keyframe: median {statistics.median(times):.3f} s,"
              f" min {min(times):.3f} s over {repeats} runs (load average {os.getloadavg()[0]:.1f})")


def end_to_end(shots: list[str], methods: tuple[str, ...] = METHODS) -> None:
    """Mean interior PSNR per shot: ours with each predictor, RIFE-direct (each setting in its own home)."""
    from ops.evaluation.baselines import summarize
    from ops.settings import Settings

    homes = {m: tempfile.mkdtemp(prefix=f"bench_occ_{m}_") for m in methods}
    results: dict[str, dict] = defaultdict(dict)
    for m in methods:
        os.environ["INBETWEEN_HOME"] = homes[m]  # read on every call (assets/home.py)
        from assets.run import evaluate_stages, run_shot, store

        for name in shots:
            d = ROOT / "data_samples" / name
            t0 = time.perf_counter()
            run_shot(d, Path(homes[m]) / "out" / name, Settings(occlusion=m))
            partition = evaluate_stages(d, Settings(occlusion=m))
            per_shot = summarize(store().read("evaluation/metrics", partition).assign(shot=name))
            psnr = dict(zip(per_shot["method"], per_shot["psnr"]))
            results[name][m] = psnr["ours"]
            results[name]["rife_direct"] = psnr["rife_direct"]
            masks = store().read("key1/masks", partition)
            results[name][f"{m} regions"] = len(masks.occlusion)
            print(f"{name}: occlusion={m}: ours {psnr['ours']:.2f} dB, RIFE-direct {psnr['rife_direct']:.2f} dB "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    print("\n| shot | " + " | ".join(f"ours, {m}" for m in methods) + " | RIFE direct |\n|---|" + "---|" * len(methods) + "---|")
    for name in shots:
        r = results[name]
        print(f"| {name} | " + " | ".join(f"{r[m]:.2f} ({r[f'{m} regions']})" for m in methods)
              + f" | {r['rife_direct']:.2f} |")
    print("(in brackets: key1's occlusion regions)")


# AnimatedDrawings skeletons carry no depth: z by eye from each drawing (smaller = nearer the viewer)
REAL_DEPTHS = {
    # round kid: arms in front of the body, legs hang behind the belly line
    "char1": {"right_shoulder": -0.3, "right_elbow": -0.5, "right_hand": -0.5, "left_shoulder": -0.3,
              "left_elbow": -0.5, "left_hand": -0.5, "right_knee": 0.3, "right_foot": 0.3, "left_knee": 0.3,
              "left_foot": 0.3},
    # girl in a skirt: the skirt (on the hips) covers the tops of the thighs
    "char2": {"right_knee": 0.4, "right_foot": 0.4, "left_knee": 0.4, "left_foot": 0.4, "right_elbow": -0.3,
              "right_hand": -0.3, "left_elbow": -0.3, "left_hand": -0.3},
    # pig in side view: its right legs are the near ones (over the belly), its left legs the far ones (under it)
    "char6": {"right_hip_b": -0.3, "right_knee_b": -0.5, "right_foot_b": -0.5, "right_hip_f": -0.3,
              "right_knee_f": -0.5, "right_foot_f": -0.5, "left_hip_b": 0.3, "left_knee_b": 0.5, "left_foot_b": 0.5,
              "left_hip_f": 0.3, "left_knee_f": 0.5, "left_foot_f": 0.5},
}
REGION_COLOURS = np.array([(230, 25, 75), (60, 180, 75), (0, 130, 200), (245, 130, 48), (145, 30, 180),
                           (70, 240, 240), (240, 50, 230), (210, 245, 60), (0, 128, 128), (170, 110, 40)], np.uint8)


def real_skeleton(cfg: dict, depths: dict[str, float]) -> tuple[Skeleton, np.ndarray]:
    """Skeleton and (J, 3) pose of an AnimatedDrawings char_cfg.yaml, with z from `depths` (0 elsewhere)."""
    names = [j["name"] for j in cfg["skeleton"]]
    parents = np.array([names.index(j["parent"]) if j["parent"] else -1 for j in cfg["skeleton"]], np.int64)
    pose = np.array([[*j["loc"], depths.get(j["name"], 0.0)] for j in cfg["skeleton"]], np.float64)
    return Skeleton(tuple(names), parents), pose


def overlay(image: np.ndarray, regions: list[np.ndarray], fronts: list[np.ndarray], pose: np.ndarray,
            skeleton: Skeleton, fg: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8: the drawing, the foreground's outline in grey, each region tinted, front bones thick."""
    out = image.copy()
    edge = fg & ~cv2.erode(fg.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    out[edge] = (128, 128, 128)
    for i, r in enumerate(regions):
        out[r] = (0.45 * out[r] + 0.55 * REGION_COLOURS[i % len(REGION_COLOURS)]).astype(np.uint8)
    front = {int(b): i for i, f in enumerate(fronts) for b in f}
    width = max(1, round(max(image.shape[:2]) / 250))
    for b, (p, c) in enumerate(skeleton.bones):
        a, e = tuple(int(v) for v in pose[p, :2]), tuple(int(v) for v in pose[c, :2])
        colour = tuple(int(v) for v in REGION_COLOURS[front[b] % len(REGION_COLOURS)]) if b in front else (0, 0, 0)
        cv2.line(out, a, e, colour, 3 * width if b in front else width, cv2.LINE_AA)
    return out


def real_drawings(realdev: Path, out_dir: Path) -> None:
    """Predicted masks on AnimatedDrawings characters (REALDEV_DIR/animated_drawings/charN), given the person-made
    foreground and the predicted one, as the masks stage makes them: OUT/charN.png = drawing | drawing predictor
    (true fg) | (predicted fg) | hybrid (predicted fg) | skeleton rule (true fg); front bones drawn thick."""
    import yaml

    out_dir.mkdir(parents=True, exist_ok=True)
    root = realdev / "animated_drawings" if (realdev / "animated_drawings").is_dir() else realdev
    for name, depths in REAL_DEPTHS.items():
        d = root / name
        if not (d / "char_cfg.yaml").exists():
            raise SystemExit(f"{d}: no char_cfg.yaml; fix: pass --real the folder that holds animated_drawings/char1 ...")
        image = cv2.cvtColor(cv2.imread(str(d / "texture.png"), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
        true_fg = cv2.imread(str(d / "mask.png"), cv2.IMREAD_GRAYSCALE) > 127
        skeleton, pose = real_skeleton(yaml.safe_load((d / "char_cfg.yaml").read_text()), depths)
        pred_fg = segment_foreground(image.astype(np.float32) / 255.0, pose, skeleton).mask
        panels = [image]
        for fg, method in ((true_fg, "drawing"), (pred_fg, "drawing"), (pred_fg, "hybrid"), (true_fg, "skeleton")):
            t0 = time.perf_counter()
            if method == "drawing":  # as the masks stage calls it: no pockets where joined bones meet
                regions, fronts, _ = drawing_occlusion(image, fg, pose, skeleton, joint_overlaps=False)
            else:
                regions, fronts, _ = skeleton_occlusion(fg, pose, skeleton)
                if method == "hybrid":
                    regions = shape_by_drawing(regions, fronts, image, fg, pose, skeleton)
            dt = time.perf_counter() - t0
            panels.append(overlay(image, regions, fronts, pose, skeleton, fg))
            names = ["+".join(skeleton.joints[skeleton.bones[b][1]] for b in f) for f in fronts]
            print(f"{name} {image.shape[1]}x{image.shape[0]} {method:8s} fg={'mask.png' if fg is true_fg else 'predicted'}: "
                  f"{len(regions)} regions ({dt:.2f} s), front bones (child joint): {', '.join(names)}")
        path = out_dir / f"{name}.png"
        cv2.imwrite(str(path), cv2.cvtColor(np.concatenate(panels, axis=1), cv2.COLOR_RGB2BGR))
        print(f"written {path}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "occ_cache",
                    help="sample cache (tools/occlusion_data.py); missing samples are generated")
    ap.add_argument("--bvh", type=Path, default=None, help="folder of .bvh clips, as the training data had")
    ap.add_argument("--n", type=int, default=60, help="samples per validation set")
    ap.add_argument("--sets", nargs="*", default=list(SETS), choices=SETS, help="validation sets")
    ap.add_argument("--rows", action="store_true", help="print one row per test keyframe")
    ap.add_argument("--no-fronts", action="store_true", help="skip the pair regions' fronts")
    ap.add_argument("--e2e", action="store_true", help="also run the sample shots end to end (slow)")
    ap.add_argument("--shots", nargs="*", default=list(OCCLUSION_SHOTS), help="shots for --e2e")
    ap.add_argument("--e2e-methods", nargs="*", default=list(METHODS), choices=METHODS, help="predictors for --e2e")
    ap.add_argument("--only-e2e", action="store_true", help="skip the validation sets, fronts, shots and timing")
    ap.add_argument("--real", type=Path, help="REALDEV_DIR: also write overlays of predicted masks on its real "
                                               "drawings (kept out of the repository)")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "occlusion_real",
                    help="where --real writes its overlays")
    ap.add_argument("--weights", type=Path, default=None,
                    help="a candidate weights file for the network (default: the shipped one), e.g. an older one")
    args = ap.parse_args(argv)
    bvh = str(args.bvh) if args.bvh else None
    if args.weights:
        print(f"network weights {args.weights} (sha256 {use_weights(args.weights)})")
    print(f"default predictor (Settings.occlusion): {Settings().occlusion}")
    if args.only_e2e:
        end_to_end(args.shots, tuple(args.e2e_methods))
        return
    t0 = time.perf_counter()
    if args.rows:
        print("per keyframe IoU: " + "  ".join(f"{m}|{f}" for f in ("gt fg", "pred fg") for m in METHODS))
    table = score_sets(args.sets, args.n, args.cache, bvh, args.rows)
    print_summary(table, "set", f"Validation sets (never trained on), {args.n} samples each: mean IoU "
                                f"({time.perf_counter() - t0:.0f} s)")
    for name in args.sets:
        print_summary(table, "label", f"{name}: mean IoU per class / body family", within=name)
        print_summary(table, "style", f"{name}: mean IoU per style", within=name)
        if name.startswith("3d"):
            print_summary(table, "view", f"{name}: mean IoU per view", within=name)
    if not args.no_fronts:
        front_accuracy([s for s in args.sets if s.startswith("3d")], args.n, args.cache, bvh)
    print_summary(sample_shots(), "label", "Sample shots (data_samples/*/gt_occ/key{k}_union.png)")
    print()
    timing()
    if args.real:
        real_drawings(args.real, args.out)
    if args.e2e:
        end_to_end(args.shots, tuple(args.e2e_methods))


if __name__ == "__main__":
    main()
