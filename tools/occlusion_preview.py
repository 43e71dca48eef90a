"""A contact sheet of the occlusion predictor on the validation sets: drawing | truth | the drawing predictor's pair
regions (as the masks stage makes them), front bones thick, per sample its IoU.

    python tools/occlusion_preview.py --cache CACHE_DIR --bvh BVH_DIR --out docs/occlusion_preview.png [--n 4]

Rows: per validation set (tools/occlusion_eval.py) its first n samples with an occlusion, the 3D sets' side and
three-quarter views first. A failure shows at a glance: regions where the truth has none, a limb over the body
left unmarked, a front bone drawn thick on the wrong part.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from tools.occlusion_eval import SETS, iou, load_set, union_of, use_weights  # noqa: E402

TILE = 200
COLOURS = np.array([(230, 25, 75), (60, 180, 75), (0, 130, 200), (245, 130, 48), (145, 30, 180), (70, 240, 240),
                    (240, 50, 230), (210, 245, 60), (0, 128, 128), (170, 110, 40)], np.uint8)


def tile(img: np.ndarray, text: str) -> np.ndarray:
    """(TILE, TILE, 3) uint8: img letterboxed, with a caption."""
    h, w = img.shape[:2]
    k = TILE / max(h, w)
    small = cv2.resize(img, (max(1, int(w * k)), max(1, int(h * k))), interpolation=cv2.INTER_AREA)
    out = np.full((TILE, TILE, 3), 255, np.uint8)
    y0, x0 = (TILE - small.shape[0]) // 2, (TILE - small.shape[1]) // 2
    out[y0:y0 + small.shape[0], x0:x0 + small.shape[1]] = small
    cv2.putText(out, text, (3, 11), cv2.FONT_HERSHEY_SIMPLEX, 0.33, (0, 0, 0), 1, cv2.LINE_AA)
    return out


def panels(d: dict) -> list[np.ndarray]:
    """The three panels of one sample."""
    from ops.segmentation.occlusion_drawing import predict_occlusion

    image, fg, pose, sk = d["image"], d["fg"] > 127, d["pose"], d["skeleton"]
    truth = image.copy()
    truth[d["union"]] = (0.45 * truth[d["union"]] + 0.55 * np.array([0, 90, 255])).astype(np.uint8)
    regions, fronts, _ = predict_occlusion(image, fg, pose, sk, joint_overlaps=False)
    every = union_of(predict_occlusion(image, fg, pose, sk)[0], fg.shape)
    pred = image.copy()
    for i, r in enumerate(regions):
        pred[r] = (0.45 * pred[r] + 0.55 * COLOURS[i % len(COLOURS)]).astype(np.uint8)
    front = {int(b): i for i, f in enumerate(fronts) for b in f}
    for b, (p, c) in enumerate(sk.bones):
        a, e = tuple(int(v) for v in pose[p, :2]), tuple(int(v) for v in pose[c, :2])
        colour = tuple(int(v) for v in COLOURS[front[b] % len(COLOURS)]) if b in front else (0, 0, 0)
        cv2.line(pred, a, e, colour, 3 if b in front else 1, cv2.LINE_AA)
    label = f"{d['set'].replace('3d ', '')}: {d['label']} {d['style']} {d['view']}".strip()
    return [tile(image, label), tile(truth, "truth (joint overlaps too)"),
            tile(pred, f"pair regions, IoU {iou(every, d['union']):.2f} (with joints)")]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, required=True)
    ap.add_argument("--bvh", type=Path, default=None)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--n", type=int, default=4, help="samples per set")
    ap.add_argument("--weights", type=Path, default=None, help="a candidate weights file (default: the shipped one)")
    args = ap.parse_args(argv)
    if args.weights:
        use_weights(args.weights)
    rows = []
    for name in SETS:
        items = [d for d in load_set(name, 4 * args.n, args.cache, str(args.bvh) if args.bvh else None)
                 if d["union"].any()]
        items.sort(key=lambda d: d["view"] not in ("side", "three_quarter"))  # stable: side views first
        for k in range(0, min(len(items), args.n), 2):
            row = [p for d in items[k:k + 2] for p in panels(d)]
            row += [np.full((TILE, TILE, 3), 255, np.uint8)] * (6 - len(row))
            rows.append(np.concatenate(row, axis=1))
    sheet = np.concatenate(rows, axis=0)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
    print(f"written {args.out} ({sheet.shape[1]}x{sheet.shape[0]})")


if __name__ == "__main__":
    main()
