"""The two lanes and their blend side by side, per output time, from a finished run: what issue 27 asks a closing
note to show.

    python tools/lanes_figure.py SHOT_DIR --home INBETWEEN_HOME --out lanes.png [--segment 0] [--every 2]

Rows: key0's lane (its template deformed through the motion: the image matrix at alpha 0), key1's lane (alpha 1),
the blend the optimal path takes (the segment's output frames, per-pixel alpha included; the path's alpha
printed), and the shot's ground truth where it has one. Columns: the
segment's output times (every `every`-th, the keys always). Every tile is cropped to the union of what the lanes
draw, so the lanes' disagreement (a limb in two places, a tear, a smear) shows at the same place in each column.
The lanes and the blend are shown over the paper the evaluation judges them on (ops.evaluation.plate: the keys'
bare paper), and with a ground truth each tile's caption gives its PSNR against it, over the whole frame.
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

from ops.evaluation.metrics import psnr  # noqa: E402
from ops.evaluation.plate import over, paper_plate  # noqa: E402
from ops.shotio.image_io import composite_over_white, read_image, to_rgba, write_image  # noqa: E402
from ops.shotio.load import ground_truth_files, load_shot  # noqa: E402
from resources.registry import partition_of  # noqa: E402
from resources.store import Store  # noqa: E402

TILE = 220  # px per tile side
LABEL_W = 90  # px of the row labels


def on_white(image: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32 0-1: any image (straight-alpha RGBA, RGB, grey) composited over white."""
    return composite_over_white(to_rgba(image))


def crop_box(alphas: list[np.ndarray], margin: int = 6) -> tuple[int, int, int, int]:
    """(y0, y1, x0, x1) of everything the (H, W) 0-1 coverages draw, a margin around, squared."""
    ink = np.any([a > 0.03 for a in alphas], axis=0)
    ys, xs = np.nonzero(ink)
    h, w = ink.shape
    if not len(ys):
        return 0, h, 0, w
    y0, y1, x0, x1 = ys.min() - margin, ys.max() + 1 + margin, xs.min() - margin, xs.max() + 1 + margin
    side = max(y1 - y0, x1 - x0)
    cy, cx = (y0 + y1) // 2, (x0 + x1) // 2
    y0, x0 = int(np.clip(cy - side // 2, 0, max(h - side, 0))), int(np.clip(cx - side // 2, 0, max(w - side, 0)))
    return y0, min(y0 + side, h), x0, min(x0 + side, w)


def tile(img: np.ndarray, box: tuple[int, int, int, int], caption: str) -> np.ndarray:
    """(TILE, TILE, 3) uint8: img (H, W, 3) 0-1 cropped to box, scaled to fit, captioned."""
    y0, y1, x0, x1 = box
    crop = (np.clip(img[y0:y1, x0:x1], 0, 1) * 255).astype(np.uint8)
    k = (TILE - 14) / max(crop.shape[:2])
    small = cv2.resize(crop, (max(1, round(crop.shape[1] * k)), max(1, round(crop.shape[0] * k))),
                       interpolation=cv2.INTER_AREA if k < 1 else cv2.INTER_LINEAR)
    out = np.full((TILE, TILE, 3), 255, np.uint8)
    oy, ox = 14 + (TILE - 14 - small.shape[0]) // 2, (TILE - small.shape[1]) // 2
    out[oy:oy + small.shape[0], ox:ox + small.shape[1]] = small
    cv2.putText(out, caption, (3, 11), cv2.FONT_HERSHEY_SIMPLEX, 0.36, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.rectangle(out, (0, 0), (TILE - 1, TILE - 1), (200, 200, 200), 1)
    return out


def lane_rows(frames: np.ndarray, alpha_index: np.ndarray, cols: list[int], plate: np.ndarray,
              blended: np.ndarray | None = None) -> list[tuple[str, list[np.ndarray]]]:
    """Rows of (H, W, 3) 0-1 images from the image matrix's frames (T, A, H, W, 4): key0's lane (alpha 0), key1's
    (alpha 1) and the path's blend at the times cols, each over the (H, W, 3) paper plate. The blend: the output
    frames `blended` (T, H, W, 4) where given, else the path's cells (alpha_index (T,))."""
    picks = [("key0 lane", lambda c: frames[c, 0]), ("key1 lane", lambda c: frames[c, -1]),
             ("blend", lambda c: frames[c, alpha_index[c]] if blended is None else blended[c])]
    return [(name, [over(np.asarray(pick(c), np.float32)[None], plate)[0] for c in cols]) for name, pick in picks]


def lanes_figure(shot_dir: Path, home: Path, segment: int = 0, every: int = 1) -> np.ndarray:
    """(H, W, 3) uint8 figure of a stored run of shot_dir (its stages in home/storage): rows as the module says."""
    shot = load_shot(shot_dir)
    store = Store(home / "storage")
    # the run's key for this folder (a second shot of the same name is `name-<hash>`); a bare store: its name
    partition = partition_of(home / "shots.json", shot_dir) or shot_dir.resolve().name
    matrix = store.read(f"seg{segment}/rife_matrix", partition)
    paths = store.read(f"seg{segment}/optimal_path", partition)
    try:  # the output frames (per-pixel alpha included); a store without them: the path's cells
        blended = store.read(f"seg{segment}/frames", partition).frames
    except (KeyError, FileNotFoundError):
        blended = None
    n_t = len(matrix.times)
    cols = sorted(set(range(0, n_t, max(every, 1))) | {n_t - 1})
    first = shot.key_frames[segment]  # the segment's first output frame
    truth = {}
    if shot.ground_truth:
        files = {int(f.stem): f for f in ground_truth_files(shot.ground_truth)}
        truth = {c: on_white(read_image(files[first + c], "ground_truth")) for c in cols if first + c in files}
    alpha = paths.optimal.alpha_index
    keys = shot.segment_keys(segment)
    masks = [store.read(f"key{k}/masks", partition) for k in keys]
    plate = paper_plate([to_rgba(read_image(shot.keyframes[k], "keyframes")) for k in keys],
                        [m.coverage for m in masks], [m.paper for m in masks])
    box = crop_box([matrix.frames[c, a, ..., 3] for c in cols for a in (0, -1, alpha[c])])  # not the truth's paper
    rows = lane_rows(matrix.frames, alpha, cols, plate, blended)
    if truth:
        blank = np.ones_like(rows[0][1][0])
        rows.append(("truth", [truth.get(c, blank) for c in cols]))
    lines = []
    for name, ims in rows:
        tiles = []
        for c, im in zip(cols, ims):
            caption = f"t={matrix.times[c]:.2f}" + (f" a={matrix.alphas[alpha[c]]:.3f}" if name == "blend" else "")
            if c in truth and name != "truth":
                caption += f" {psnr(im, truth[c]):.1f}dB"
            tiles.append(tile(im, box, caption))
        label = np.full((TILE, LABEL_W, 3), 255, np.uint8)
        cv2.putText(label, name, (4, TILE // 2), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
        lines.append(np.hstack([label, *tiles]))
    return np.vstack(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("shot", type=Path, help="the shot folder that was run")
    ap.add_argument("--home", type=Path, required=True, help="the run's INBETWEEN_HOME")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--segment", type=int, default=0)
    ap.add_argument("--every", type=int, default=1, help="every n-th output time (the keys always)")
    args = ap.parse_args()
    fig = lanes_figure(args.shot, args.home, args.segment, args.every)
    write_image(args.out, fig.astype(np.float32) / 255.0)
    print(f"written: {args.out} ({fig.shape[1]}x{fig.shape[0]})")


if __name__ == "__main__":
    main()
