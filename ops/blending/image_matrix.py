"""The image matrix I(alpha, t): RIFE blends of the two deformed sequences (§5.2).

Row t blends the frame deformed from keyframe 0 (alpha = 0) into the frame
deformed from keyframe 1 (alpha = 1). RIFE HDv3 only predicts midpoints, so
the alpha grid is dyadic. Its cells come one of two ways (`cells`):

- "bisection" (the paper's): recursive bisection, level 1 the midpoint of the
  two ends, level l the midpoints of neighbours at level l - 1: a cell at an
  eighth costs three network calls.
- "scaled" (the pipeline's default): the network runs once per row, at
  alpha 1/2; every other cell warps and blends the row's two frames with that
  call's flows scaled to alpha and its fusion mask reweighted
  (ops/blending/rife_onnx.py scaled_flow_mask). On the sample and held-out
  shots these cells are 46-50 dB from bisection's on average and as near the
  ground truth (+0.11 and +0.01 dB), at one call a row instead of up to three
  (docs/performance.md).

Rows are processed in chunks so a long shot only needs one chunk in memory.
Scaled cells are kept in half precision (cell_dtype): a frame's 8-bit levels
are 1/255 apart and a half's step below 1 is 1/2048 (the EXR frames are half
already), at half the memory of the cells and of what the store writes and
hashes for them (arm_cross's stored matrix 95 -> 60 MB, its flows and masks
kept single; hashed and written 0.18 -> 0.11 s alone, and 0.51 -> 0.08 s in an
edit, whose last half second had waited on that write). Bisected cells stay
single: a cell read back as a parent would feed its rounding into the network.
The blending itself is single precision either way.
"""
from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING

import numpy as np

from ops.cputime import charge, thread_cpu
from ops.types import ImageMatrix

if TYPE_CHECKING:
    from ops.blending.rife import Rife
    from ops.blending.rife_onnx import OnnxRife

CELLS = ("scaled", "bisection")  # how the cells off alpha 1/2 are made (module docstring)


def alpha_grid(depth: int) -> np.ndarray:
    """(2**depth + 1,) float64 dyadic grid {0, 1/2**depth, ..., 1}; depth >= 1 so that 1/2 is on it."""
    if depth < 1:
        raise ValueError(f"alpha depth must be >= 1, got {depth}")
    n = 2**depth
    return np.arange(n + 1, dtype=np.float64) / n


def bisection_levels(depth: int) -> list[np.ndarray]:
    """Per level, (k, 3) int64 alpha-index triples (left, middle, right) filled at that level."""
    n = 2**depth
    levels = []
    for level in range(1, depth + 1):
        half = n >> level  # distance in grid steps from a new point to its two parents
        mids = np.arange(half, n, 2 * half, dtype=np.int64)
        levels.append(np.stack([mids - half, mids, mids + half], axis=1))
    return levels


def _check_inputs(frames0: np.ndarray, frames1: np.ndarray, times: np.ndarray) -> None:
    """Raise ValueError unless frames are two (T, H, W, 4) arrays matching len(times)."""
    if frames0.shape != frames1.shape or frames0.ndim != 4 or frames0.shape[3] != 4:
        raise ValueError(f"frames must be two (T, H, W, 4) arrays of equal shape, got {frames0.shape}, {frames1.shape}")
    if len(times) != frames0.shape[0]:
        raise ValueError(f"{len(times)} times for {frames0.shape[0]} frames")


def cell_dtype(cells: str) -> type:
    """The dtype of a matrix's cells made the `cells` way (module docstring); flows and masks are float32."""
    return np.float16 if cells == "scaled" else np.float32


def _check_out(out: np.ndarray | None, shape: tuple[int, ...], name: str, dtype=np.float32) -> np.ndarray:
    """Allocate zeroed `dtype` `shape` if `out` is None, else check it has that shape and dtype."""
    if out is None:
        # zeros, not empty: the pages of the cells never computed are never touched (most of a path's matrix)
        return np.zeros(shape, dtype=dtype)
    if out.shape != shape or out.dtype != dtype:
        raise ValueError(f"{name} must be {np.dtype(dtype).name} {shape}, got {out.dtype} {out.shape}")
    return out


def bisection_closure(wanted: np.ndarray, depth: int) -> np.ndarray:
    """wanted: (T, A) bool cells -> (T, A) bool: them, every cell their bisection needs first, both ends, and
    alpha = 1/2 (its flow is the matrix's flow)."""
    need = np.array(wanted, dtype=bool)
    need[:, [0, -1, need.shape[1] // 2]] = True
    for triples in bisection_levels(depth)[::-1]:  # deepest first: a parent is marked before its own level
        lo, mid, hi = triples.T
        need[:, lo] |= need[:, mid]
        need[:, hi] |= need[:, mid]
    return need


def network_calls_bound(n_times: int, depth: int, cells: str) -> int:
    """The most network calls (image pairs) a matrix of n_times rows makes for one path's cells: the alpha-1/2
    call of every row, and with bisected cells at most depth - 1 more per row (a cell at the deepest level)."""
    return n_times * (1 if cells == "scaled" else depth)


def scaled_closure(wanted: np.ndarray) -> np.ndarray:
    """wanted: (T, A) bool cells -> (T, A) bool: them, both ends and alpha = 1/2 (the scaled cells need nothing
    else)."""
    need = np.array(wanted, dtype=bool)
    need[:, [0, -1, need.shape[1] // 2]] = True
    return need


def _fill_chunk(cells, todo: np.ndarray, depth: int, rife: Rife | OnnxRife, batch: int, flows, masks) -> None:
    """Fill cells (c, A, 4, H, W) (the runtime's arrays, on its device) in place where todo (c, A) is set: by
    bisection, level by level from their parents, which must be known, when masks is None; else the alpha-1/2
    cells by the network and the others scaled from their row's flows and masks (c, 1, H, W), which must be
    known where the alpha-1/2 cell is not in todo. The alpha-1/2 calls write their flow into flows (c, 4, H, W)
    (and their mask into masks)."""
    half = todo.shape[1] // 2
    for level, triples in enumerate(bisection_levels(depth)[:1] if masks is not None else bisection_levels(depth)):
        # every (row, triple) pair of this level is independent: batch them across rows
        pairs = np.array([(r, *tri) for r in range(len(cells)) for tri in triples if todo[r, tri[1]]], np.int64)
        for s in range(0, len(pairs), batch):
            r, lo, mid, hi = (rife.index(c) for c in pairs[s:s + batch].T)
            if masks is None:
                cells[r, mid], flow = rife.midpoint_tensors(cells[r, lo], cells[r, hi])
            else:
                cells[r, mid], flow, masks[r] = rife.midpoint_flow_mask(cells[r, lo], cells[r, hi])
            if level == 0:
                flows[r] = flow
    if masks is None:
        return
    alphas = alpha_grid(depth)
    for a in range(1, todo.shape[1] - 1):
        rows = np.nonzero(todo[:, a])[0] if a != half else []
        if len(rows):
            r = rife.index(rows)
            cells[r, a] = rife.blend_at(cells[r, 0], cells[r, -1], flows[r], masks[r], alphas[a])


def build_image_matrix(frames0: np.ndarray, frames1: np.ndarray, times: np.ndarray, rife: Rife | OnnxRife,
                       depth: int = 3, batch: int = 1, out: np.ndarray | None = None,
                       flows_out: np.ndarray | None = None,
                       wanted: Callable[[np.ndarray], np.ndarray] | None = None,
                       computed: np.ndarray | None = None, cells: str = "bisection",
                       masks_out: np.ndarray | None = None) -> ImageMatrix:
    """frames0, frames1: (T, H, W, 4) straight RGBA -> ImageMatrix with frames (T, 2**depth + 1, H, W, 4)
    (cell_dtype(cells)).

    `cells`: "bisection" or "scaled" (module docstring); a scaled matrix keeps
    each row's alpha-1/2 fusion mask (`masks`, (T, H, W)) to make more cells
    later. `wanted(flows)`, given the (T, H, W, 4) flows at alpha 1/2, returns
    the (T, A) bool cells to compute: those and what they need (their
    bisection's parents, or alpha 1/2) are filled, the other cells are left
    zero and marked not computed. None: all.
    `batch` bounds the image pairs per RIFE call; rows are processed in chunks
    of `batch` rows, kept on the network's device between bisection levels, so
    beyond `out` (cell_dtype(cells), optionally a np.memmap) and `flows_out` ((T, H, W, 4),
    likewise) only one chunk is held in memory. On a CPU one pair per call is
    fastest (larger batches fall out of cache); on a GPU use 8 or more.
    `computed` ((T, A) bool, with `out`, `flows_out` and, for scaled cells,
    `masks_out` holding those cells and the alpha-1/2 flows and masks of a
    matrix built before) marks cells already blended: they are kept, and only
    what `wanted` adds is blended (complete_cells).
    """
    _check_inputs(frames0, frames1, times)
    if batch < 1:
        raise ValueError(f"batch must be >= 1, got {batch}")
    if cells not in CELLS:
        raise ValueError(f"cells {cells!r}: use one of {', '.join(CELLS)}")
    scaled = cells == "scaled"
    closure = scaled_closure if scaled else (lambda want: bisection_closure(want, depth))
    alphas = alpha_grid(depth)
    t_count, h, w, _ = frames0.shape
    n_a = len(alphas)
    given = out is not None
    out = _check_out(out, (t_count, n_a, h, w, 4), "out", cell_dtype(cells))
    flows_out = _check_out(flows_out, (t_count, h, w, 4), "flows_out")
    masks_out = _check_out(masks_out, (t_count, h, w), "masks_out") if scaled else None
    need = closure(np.zeros((t_count, n_a), bool) if wanted else np.ones((t_count, n_a), bool))
    if computed is None:
        computed = np.zeros((t_count, n_a), bool)
    else:  # a matrix built before: its alpha-1/2 cells and flows are known, so the wanted cells are decided now
        computed = np.array(computed, bool)
        if computed.shape != (t_count, n_a) or not computed[:, n_a // 2].all():
            raise ValueError(f"computed must be ({t_count}, {n_a}) bool with every alpha-1/2 cell set")

    def fill(t0: int, phase: int) -> None:
        """Rows t0 .. t0 + batch: their cells to compute in this phase, level by level (they touch no other row)."""
        rows = slice(t0, min(t0 + batch, t_count))
        known = np.nonzero(computed[rows].any(0))[0] if phase else []
        chunk = rife.empty((rows.stop - t0, n_a, 4, h, w))
        chunk[:, 0], chunk[:, -1] = rife.rgba_tensor(frames0[rows]), rife.rgba_tensor(frames1[rows])
        for a in known:
            chunk[:, a] = rife.rgba_tensor(np.ascontiguousarray(out[rows, a]))
        todo = need[rows] & ~computed[rows]
        todo[:, [0, -1]] = False
        flows = rife.zeros((rows.stop - t0, 4, h, w))
        masks = rife.zeros((rows.stop - t0, 1, h, w)) if scaled else None
        if scaled and computed[rows, n_a // 2].any():  # the scaled cells of known rows need their flows and masks
            flows[:] = rife.rgba_tensor(np.ascontiguousarray(flows_out[rows]))
            masks[:] = rife.rgba_tensor(np.ascontiguousarray(masks_out[rows, ..., None]))
        _fill_chunk(chunk, todo, depth, rife, batch, flows, masks)
        done = todo | computed[rows]
        done[:, [0, -1]] = True
        for a in range(n_a):  # only what is new goes back to the host
            fresh = np.nonzero(done[:, a] & ~computed[rows, a])[0]
            if len(fresh):
                out[t0 + fresh, a] = rife.to_host(chunk[rife.index(fresh), a])
        if todo[:, n_a // 2].any():
            flows_out[rows] = rife.to_host(flows)
            if scaled:
                masks_out[rows] = rife.to_host(masks)[..., 0]
        computed[rows] = done

    # chunks of rows are independent: a runtime that is faster with several calls at once (ONNX Runtime on the
    # CPU: OnnxRife.concurrency) fills them on that many threads; the chunks left over once the others are
    # paired (the ninth of nine level-1 calls on two threads) run after them on all the threads, not on a share
    at_once = min(rife.concurrency() if hasattr(rife, "concurrency") else 1, -(-t_count // batch))
    pool = ThreadPoolExecutor(at_once, thread_name_prefix="inbetween-matrix") if at_once > 1 else None
    try:
        for phase in (0, 1) if wanted and not computed.any() else (1,):
            if phase == 1 and wanted:  # the level-1 flows are known now: decide the rest
                need = closure(wanted(flows_out))
            chunks = range(0, t_count, batch)
            if pool is None:
                for t0 in chunks:
                    fill(t0, phase)
                continue
            work = need & ~computed
            work[:, [0, -1]] = False
            busy = [t0 for t0 in chunks if work[t0:t0 + batch].any()]
            paired = busy[:len(busy) - len(busy) % at_once]
            with rife.calls_at_once(at_once):
                for cpu in pool.map(thread_cpu(fill), paired, [phase] * len(paired)):  # re-raises a chunk's error
                    charge(cpu)  # the pool's CPU is the caller's (a stage's cpu_seconds)
            for t0 in chunks:
                if t0 not in paired:
                    fill(t0, phase)
    finally:
        if pool is not None:
            pool.shutdown()
    if given:  # not computed: transparent black, and marked so (a fresh array is zero already)
        out[~computed] = 0.0
    return ImageMatrix(times=np.asarray(times, dtype=np.float64), alphas=alphas, frames=out, flows=flows_out,
                       computed=computed, masks=masks_out)


def complete_cells(matrix: ImageMatrix, frames0: np.ndarray, frames1: np.ndarray, rife: Rife | OnnxRife,
                   alpha_index: np.ndarray, batch: int = 1) -> ImageMatrix:
    """The matrix with the cells (t, alpha_index[t]) of another path blended too (and, for a bisected matrix,
    their bisection's parents), made as the matrix made its own (scaled where it kept its masks); cells it has
    are kept, not recomputed. frames0, frames1: the (T, H, W, 4) deformed sequences it was built from;
    alpha_index: (T,) int64. The matrix itself is not changed."""
    t_count, n_a = matrix.computed.shape
    want = np.zeros((t_count, n_a), bool)
    want[np.arange(t_count), np.asarray(alpha_index, np.int64)] = True
    if (matrix.computed | ~want).all():
        return matrix
    depth = int(round(np.log2(n_a - 1)))
    scaled = matrix.masks is not None
    cells = "scaled" if scaled else "bisection"
    return build_image_matrix(frames0, frames1, matrix.times, rife, depth=depth, batch=batch,
                              out=np.array(matrix.frames, cell_dtype(cells)),
                              flows_out=np.array(matrix.flows, np.float32), wanted=lambda flows: want,
                              computed=matrix.computed, cells=cells,
                              masks_out=np.array(matrix.masks, np.float32) if scaled else None)
