"""Occlusion masks (issue 15): IoU of the drawing predictor, the hybrid and the skeleton rule, timing, end to end.

    python benchmarks/bench_occlusion.py                       # 100 test samples, the sample shots' keys, timing
    python benchmarks/bench_occlusion.py --n 250 --rows        # more samples, one row per keyframe
    python benchmarks/bench_occlusion.py --e2e --shots arm_cross legs_cross   # + end to end (slow: minutes a shot)

IoU is per keyframe with an occlusion: the union of the predicted regions against the union of the ground
truth (issue-15 definition: every overlap of a nearer part over a farther one, joint overlaps included).
Every predictor runs twice: given the true foreground (so the numbers do not depend on the foreground
segmentation) and given the foreground that ops.segmentation.foreground predicts. The test split
(seeds 10 000 000 + index) is never used for training or tuning.

The hybrid (the default) is the skeleton rule's regions cut to the network's marks
(ops.segmentation.occlusion_drawing.shape_by_drawing).

End to end (--e2e): each shot runs through the whole graph with Settings(occlusion=m) for every predictor m in
a private INBETWEEN_HOME, then its evaluation group; printed are the mean PSNR over the interior frames of ours
with each predictor and of RIFE applied directly to the keys.
"""
from __future__ import annotations

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

from ops.segmentation.foreground import segment_foreground  # noqa: E402
from ops.segmentation.occlusion import predict_occlusion as skeleton_occlusion  # noqa: E402
from ops.segmentation.occlusion_drawing import predict_occlusion as drawing_occlusion  # noqa: E402
from ops.segmentation.occlusion_drawing import shape_by_drawing  # noqa: E402
from ops.types import Skeleton  # noqa: E402

OCCLUSION_SHOTS = ("arm_cross", "legs_cross", "tail", "two_poses", "watercolour", "flat_colour", "scan_jpeg",
                   "hand_on_hip", "lamp", "curled_tail")  # every sample shot with an occlusion in a keyframe
METHODS = ("drawing", "hybrid", "skeleton")


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two (H, W) bool masks (1 when both are empty)."""
    union = (a | b).sum()
    return float((a & b).sum() / union) if union else 1.0


def union_of(regions: list[np.ndarray], shape: tuple[int, int]) -> np.ndarray:
    """(H, W) bool union of predicted regions."""
    out = np.zeros(shape, bool)
    for r in regions:
        out |= r
    return out


def predict(method: str, image: np.ndarray, fg: np.ndarray, pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(H, W) bool union of `method`'s regions on a (H, W, 3) uint8 drawing."""
    if method == "drawing":
        regions = drawing_occlusion(image, fg, pose, skeleton)[0]
    else:
        regions, fronts, _ = skeleton_occlusion(fg, pose, skeleton)
        if method == "hybrid":
            regions = shape_by_drawing(regions, fronts, image, fg, pose, skeleton)
    return union_of(regions, fg.shape)


def score(image: np.ndarray, truth: np.ndarray, true_fg: np.ndarray, pose: np.ndarray, skeleton: Skeleton
          ) -> dict[str, float]:
    """IoU of each method given the true and the predicted foreground: {'drawing|gt fg': ..., ...}."""
    pred_fg = segment_foreground(image.astype(np.float32) / 255.0, pose, skeleton).mask
    out = {}
    for fg_name, fg in (("gt fg", true_fg), ("pred fg", pred_fg)):
        for m in METHODS:
            out[f"{m}|{fg_name}"] = iou(predict(m, image, fg, pose, skeleton), truth)
    return out


def test_split(n: int, start: int, rows: bool) -> dict[str, list]:
    """Score test samples start .. start + n - 1; prints a row per keyframe when `rows`; returns the scores."""
    from data_samples.generator.occlusion_set import make_sample

    table = defaultdict(list)
    for i in range(start, start + n):
        s = make_sample("test", i)
        skeleton = Skeleton(tuple(s.joints), np.asarray(s.parents, np.int64))
        if not s.occlusion_union.any():
            continue
        sc = score(s.image, s.occlusion_union, s.foreground > 0.5, s.pose, skeleton)
        table["label"].append(s.label)
        table["style"].append(s.style)
        for k, v in sc.items():
            table[k].append(v)
        if rows:
            print(f"test {i:4d}  {s.label:20s} {s.style:12s} " + "  ".join(f"{v:.3f}" for v in sc.values()),
                  flush=True)
    return table


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


def print_summary(table: dict[str, list], by: str, title: str) -> None:
    """Mean IoU per method, overall and per value of column `by`."""
    cols = [f"{m}|{f}" for f in ("gt fg", "pred fg") for m in METHODS]
    print(f"\n{title}\n")
    print(f"| {by} | n | " + " | ".join(cols) + " |")
    print("|---|---|" + "---|" * len(cols))
    groups = sorted(set(table[by]))
    for g in groups + ["**mean**"]:
        idx = [i for i, v in enumerate(table[by]) if v == g or g == "**mean**"]
        vals = [statistics.fmean(table[c][i] for i in idx) for c in cols]
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


def end_to_end(shots: list[str]) -> None:
    """Mean interior PSNR per shot: ours with each predictor, RIFE-direct (each setting in its own home)."""
    from ops.evaluation.baselines import summarize
    from ops.settings import Settings

    homes = {m: tempfile.mkdtemp(prefix=f"bench_occ_{m}_") for m in METHODS}
    results: dict[str, dict] = defaultdict(dict)
    for m in METHODS:
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
    print("\n| shot | " + " | ".join(f"ours, {m}" for m in METHODS) + " | RIFE direct |\n|---|" + "---|" * len(METHODS) + "---|")
    for name in shots:
        r = results[name]
        print(f"| {name} | " + " | ".join(f"{r[m]:.2f}" for m in METHODS) + f" | {r['rife_direct']:.2f} |")


REALDEV = ROOT.parent / "shared" / "realdev" / "animated_drawings"
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


def real_drawings(out_dir: Path) -> None:
    """Predicted masks on AnimatedDrawings characters (../shared/realdev), given the person-made foreground and
    the predicted one: OUT/charN.png = drawing | drawing predictor (true fg) | (predicted fg) | hybrid, the default
    (predicted fg) | skeleton rule (true fg)."""
    import yaml

    out_dir.mkdir(parents=True, exist_ok=True)
    for name, depths in REAL_DEPTHS.items():
        d = REALDEV / name
        image = cv2.cvtColor(cv2.imread(str(d / "texture.png"), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
        true_fg = cv2.imread(str(d / "mask.png"), cv2.IMREAD_GRAYSCALE) > 127
        skeleton, pose = real_skeleton(yaml.safe_load((d / "char_cfg.yaml").read_text()), depths)
        pred_fg = segment_foreground(image.astype(np.float32) / 255.0, pose, skeleton).mask
        panels = [image]
        for fg, method in ((true_fg, "drawing"), (pred_fg, "drawing"), (pred_fg, "hybrid"), (true_fg, "skeleton")):
            t0 = time.perf_counter()
            if method == "drawing":
                regions, fronts, _ = drawing_occlusion(image, fg, pose, skeleton)
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
    ap.add_argument("--n", type=int, default=100, help="test samples")
    ap.add_argument("--start", type=int, default=0, help="first test index")
    ap.add_argument("--rows", action="store_true", help="print one row per test keyframe")
    ap.add_argument("--e2e", action="store_true", help="also run the sample shots end to end (slow)")
    ap.add_argument("--shots", nargs="*", default=list(OCCLUSION_SHOTS), help="shots for --e2e")
    ap.add_argument("--threads", type=int, default=2, help="torch threads")
    ap.add_argument("--real", type=Path, help="also write overlays of predicted masks on real drawings here "
                                               "(../shared/realdev; kept out of the repository)")
    args = ap.parse_args(argv)
    import torch

    torch.set_num_threads(args.threads)
    t0 = time.perf_counter()
    if args.rows:
        print("per keyframe IoU: " + "  ".join(f"{m}|{f}" for f in ("gt fg", "pred fg") for m in METHODS))
    table = test_split(args.n, args.start, args.rows)
    print_summary(table, "label", f"Test split, samples {args.start}..{args.start + args.n - 1}: mean IoU per class "
                                  f"({time.perf_counter() - t0:.0f} s)")
    print_summary(table, "style", "Test split: mean IoU per style")
    print_summary(sample_shots(), "label", "Sample shots (data_samples/*/gt_occ/key{k}_union.png)")
    print()
    timing()
    if args.real:
        real_drawings(args.real)
    if args.e2e:
        end_to_end(args.shots)


if __name__ == "__main__":
    main()
