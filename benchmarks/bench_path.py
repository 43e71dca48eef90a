"""Every cell of the image matrix against the ground truth: which blend path is nearest the truth, per weight.

    inbetween eval SHOTS_ROOT --out EVAL_DIR               # with INBETWEEN_HOME=HOME: runs and stores every stage
    python benchmarks/bench_path.py HOME SHOTS_ROOT [--weights 0.25 1 4 16] [--cache CELLS.npz]

For each two-key shot of SHOTS_ROOT with ground truth, the stored matrix (seg0/rife_matrix of HOME's run) gets
every cell blended (the run blends only its path's), each cell is scored against the true frame at its t over
the shot's paper (the evaluation's plate and PSNR), and the optimal path (ops.blending.path) is found again for
each weight w of the Dirichlet term against q, from the run's own q and Q. Printed per shot and per group: the
mean PSNR of the interior frames along each weight's path, along the diagonal (alpha = t) and the oracle (the
best cell at each t, which no path knows), and the RIFE calls each path needs (its cells and their bisection's
parents). The weight was chosen on the samples' rows alone; shots named h00_... (held-out set), r00_...
(held-out redrawn set) and rd00_... (realdev) are reported beside them. --cache keeps the scored cells, so a rerun with other weights is quick.

The cells the run did not blend are made as the run makes them (scaled from the row's alpha-1/2 flows where its
matrix kept the masks). With --local-alpha S > 0 (the run's Settings.local_alpha by default) each cell is scored
as the frame the per-pixel alpha of strength S makes of it (ops.blending.local_alpha: what the run outputs at that
cell), and each weight's path is found twice: from the run's q, and from the q of those per-pixel frames.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import re
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from assets.blending import _table_arrays  # noqa: E402
from assets.evaluation import ground_truth  # noqa: E402
from ops.blending.image_matrix import bisection_closure, build_image_matrix, cell_dtype  # noqa: E402
from ops.blending.local_alpha import alpha_shift, local_frames, shifted_alpha  # noqa: E402
from ops.blending.path import TRANSITION_WEIGHT, optimal_path  # noqa: E402
from ops.blending.quality import unreliable_pixels  # noqa: E402
from ops.evaluation.metrics import psnr  # noqa: E402
from ops.evaluation.plate import over, paper_plate  # noqa: E402
from ops.settings import Settings  # noqa: E402
from ops.shotio.image_io import read_image, to_rgba  # noqa: E402
from ops.shotio.load import load_shot  # noqa: E402


def group(name: str) -> str:
    """The set a shot's name says it is from (benchmarks/heldout_shots.py, realdev_shots.py), else a sample."""
    for pattern, name_of_set in ((r"r\d\d_", "redrawn"), (r"rd\d\d_", "realdev"), (r"h\d\d_", "held-out")):
        if re.match(pattern, name):
            return name_of_set
    return "samples"


def local_texture_quality(seq0, seq1, alphas: np.ndarray, strength: float) -> np.ndarray:
    """(T, A) q(t, alpha) of the frame the per-pixel alpha of `strength` makes at each alpha (A,): the share of its
    character whose texture is unreliable, sum_x (1 - a(x)) c0 u0 / C0 + a(x) c1 u1 / C1, a(x) the per-pixel alpha
    (ops.blending.local_alpha), u the lanes' unreliable pixels, c their coverage and C its sum per frame. With
    strength 0 it is the run's (1 - alpha) s0 + alpha s1 (ops.blending.quality.texture_quality)."""
    u0, u1 = unreliable_pixels(seq0), unreliable_pixels(seq1)
    c0, c1 = (np.asarray(s.images[..., 3], np.float64) for s in (seq0, seq1))
    q = np.zeros((len(u0), len(alphas)))
    for t in range(len(u0)):
        w0 = np.where(u0[t], c0[t], 0.0) / max(float(c0[t].sum()), 1e-12)  # each pixel's share of s0, s1
        w1 = np.where(u1[t], c1[t], 0.0) / max(float(c1[t].sum()), 1e-12)
        shift = alpha_shift(u0[t], u1[t], strength)  # the same at every alpha: blurred once per frame
        for j, alpha in enumerate(alphas):
            a = shifted_alpha(alpha, shift).astype(np.float64)  # local_alpha's
            q[t, j] = float(((1.0 - a) * w0 + a * w1).sum())
    return q


def score_cells(store, shot, partition: str, rife, strength: float) -> dict[str, np.ndarray]:
    """{'psnr': (T, A) dB of every cell against the truth, 'q': (T, A), 'Q': (T,), 'alphas': (A,)}, and with
    strength > 0 'psnr_local': (T, A) dB of the frame each cell becomes with the per-pixel alpha of that strength
    (what the run outputs at that cell) and 'q_local': (T, A) that frame's q (local_texture_quality)."""
    matrix = store.read("seg0/rife_matrix", partition)
    seqs = [store.read(f"seg0/key{k}/deformed_frames", partition) for k in (0, 1)]
    T, A = matrix.computed.shape
    # every cell wanted, in one pass, made as the run makes them (scaled or bisected); the cells it blended are kept
    scaled = matrix.masks is not None
    kind = "scaled" if scaled else "bisection"
    matrix = build_image_matrix(seqs[0].images, seqs[1].images, matrix.times, rife, depth=int(round(np.log2(A - 1))),
                                out=np.array(matrix.frames, cell_dtype(kind)), flows_out=np.array(matrix.flows, np.float32),
                                wanted=lambda flows: np.ones((T, A), bool), computed=matrix.computed, cells=kind,
                                masks_out=np.array(matrix.masks, np.float32) if scaled else None)
    masks = [store.read(f"key{k}/masks", partition) for k in (0, 1)]
    plate = paper_plate([to_rgba(read_image(p)) for p in shot.keyframes], [m.coverage for m in masks],
                        [m.paper for m in masks])
    index, truth = ground_truth(shot)
    truth = over(truth, plate)
    P = np.full((T, A), np.nan)
    for i, t in enumerate(index):
        cells = over(np.asarray(matrix.frames[t]), plate)
        P[t] = [psnr(cells[a], truth[i]) for a in range(A)]
    _, alphas, q, Q = _table_arrays(store.read("seg0/quality_metrics", partition))
    out = {"psnr": P, "q": q, "Q": Q, "alphas": alphas}
    if strength > 0:
        PL = np.full((T, A), np.nan)
        for a, alpha in enumerate(alphas):  # column a: every row at alpha, each interior frame moved per pixel
            frames, _ = local_frames(matrix.frames[:, a], seqs[0], seqs[1], matrix, np.full(T, alpha), strength)
            for i, t in enumerate(index):
                PL[t, a] = psnr(over(frames[t], plate), truth[i])
        out |= {"psnr_local": PL, "q_local": local_texture_quality(seqs[0], seqs[1], alphas, strength)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("home", help="INBETWEEN_HOME of an `inbetween eval` of the shots")
    ap.add_argument("shots", help="the folder of shot folders that was evaluated")
    ap.add_argument("--weights", type=float, nargs="*", default=[0.25, 0.5, 1, 2, 4, 8, 16, 64])
    ap.add_argument("--cache", help=".npz of scored cells: read if it exists, else written")
    ap.add_argument("--local-alpha", type=float, default=Settings().local_alpha,
                    help="the per-pixel alpha's strength the frames are scored with (0: the cells themselves); each "
                         "path is then found twice, from the run's q and from the per-pixel frames' q")
    args = ap.parse_args()
    from resources.rife import RifeResource
    from resources.store import Store

    cache = Path(args.cache) if args.cache else None
    cells: dict[str, dict[str, np.ndarray]] = {}
    if cache and cache.is_file():
        data = np.load(cache)
        for key in data.files:
            name, field = key.split("/")
            cells.setdefault(name, {})[field] = data[key]
    else:
        store, rife = Store(Path(args.home) / "storage"), RifeResource().load()
        for d in sorted(p for p in Path(args.shots).iterdir() if (p / "shot.json").is_file()):
            shot = load_shot(d)
            if shot.n_keys != 2 or shot.ground_truth is None:
                continue
            cells[d.name] = score_cells(store, shot, d.name, rife, args.local_alpha)
            print(f"scored {d.name}", flush=True)
        if cache:
            np.savez(cache, **{f"{n}/{f}": v for n, c in cells.items() for f, v in c.items()})
    epsilon = Settings().epsilon
    local = all("psnr_local" in c for c in cells.values())
    for q_name in ("q", "q_local") if local else ("q",):
        print(f"\npaths found from {'the per-pixel frames' if q_name == 'q_local' else 'the run'}'s q, scored on "
              f"{'the per-pixel frames' if local else 'the cells'}")
        report(cells, args.weights, q_name, "psnr_local" if local else "psnr", epsilon)


def report(cells: dict[str, dict[str, np.ndarray]], weights: list[float], q_name: str, psnr_name: str,
           epsilon: float) -> None:
    """Per shot and per set, the mean PSNR (cells[..][psnr_name]) of the interior frames along the path of each
    weight found from cells[..][q_name], the diagonal's and the oracle's, and each path's RIFE calls."""
    head = [f"w={w:g}" for w in weights] + ["diagonal", "oracle"]
    print("mean PSNR of the interior frames (dB) along each path; RIFE calls of each weight's path after '|'")
    print(f"{'shot':44s} " + " ".join(f"{h:>8s}" for h in head) + " | " + " ".join(f"{h:>6s}" for h in head[:-2]))
    rows: dict[str, list[float]] = {}
    for name, c in cells.items():
        P, T = c[psnr_name], len(c[psnr_name])
        inner = range(1, T - 1)
        means, calls = [], []
        for w in weights:
            Q = c["Q"] * (w / TRANSITION_WEIGHT)  # the path's cost weighs Q by TRANSITION_WEIGHT: by w instead
            idx = optimal_path(c[q_name], Q, c["alphas"], epsilon=epsilon).alpha_index
            means.append(float(np.mean([P[t, idx[t]] for t in inner])))
            want = np.zeros(P.shape, bool)
            want[np.arange(T), idx] = True
            depth = int(round(np.log2(P.shape[1] - 1)))
            calls.append(int(bisection_closure(want, depth)[:, 1:-1].sum()))  # each interior cell: one call
        diag = np.argmin(np.abs(np.linspace(0, 1, T)[:, None] - c["alphas"][None]), axis=1)
        means += [float(np.mean([P[t, diag[t]] for t in inner])), float(np.nanmax(P[1:-1], axis=1).mean())]
        rows[name] = means + calls
        print(f"{name[:44]:44s} " + " ".join(f"{v:8.2f}" for v in means) + " | " +
              " ".join(f"{v:6d}" for v in calls))
    for g in ("samples", "held-out", "redrawn", "realdev"):
        v = np.array([r for n, r in rows.items() if group(n) == g])
        if len(v):
            m = v.mean(axis=0)
            print(f"{f'{g} mean (n={len(v)})':44s} " + " ".join(f"{x:8.3f}" for x in m[:len(head)]) + " | " +
                  " ".join(f"{x:6.1f}" for x in m[len(head):]))


if __name__ == "__main__":
    main()
