"""The image matrix as a contact sheet: columns = t, rows = alpha, with the optimal and diagonal paths (§5.2)."""
from __future__ import annotations

import cv2
import numpy as np

from ops.shotio.image_io import composite_over_white, to_rgba

PATH_COLOUR = (255, 0, 0)           # RGB 8-bit: the optimal path
DIAGONAL_COLOUR = (0, 90, 255)      # RGB 8-bit: the naive alpha = t path
SHEET_PAD = 6                       # pixels between thumbnails and around the grid
SHEET_LEFT = 56                     # label column for alpha
SHEET_TOP = 22                      # label row for t
SHEET_GREY = 237                    # 8-bit background between thumbnails
MARK_TINT = 0.6                     # output_row: how far a fully weighted pixel is tinted toward its mark's colour


def contact_sheet_shape(n_t: int, n_a: int, thumb: int) -> tuple[int, int, int]:
    """(height, width, 3) of matrix_contact_sheet for T times, A alphas, thumbnail side thumb."""
    return (SHEET_TOP + SHEET_PAD + n_a * (thumb + SHEET_PAD),
            SHEET_LEFT + SHEET_PAD + n_t * (thumb + SHEET_PAD), 3)


def _cell_origin(t: int, a: int, thumb: int) -> tuple[int, int]:
    """(x, y) top-left pixel of cell (t, alpha index a)."""
    return SHEET_LEFT + SHEET_PAD + t * (thumb + SHEET_PAD), SHEET_TOP + SHEET_PAD + a * (thumb + SHEET_PAD)


def _thumbnail(rgba: np.ndarray, thumb: int) -> np.ndarray:
    """(H, W, 4) -> (thumb, thumb, 3) uint8 over white, aspect kept, centred (letterboxed in white)."""
    rgb = composite_over_white(to_rgba(rgba))
    h, w = rgb.shape[:2]
    s = thumb / max(h, w)
    nh, nw = max(1, round(h * s)), max(1, round(w * s))
    small = cv2.resize(rgb, (nw, nh), interpolation=cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR)
    out = np.full((thumb, thumb, 3), 255, np.uint8)
    y0, x0 = (thumb - nh) // 2, (thumb - nw) // 2
    out[y0:y0 + nh, x0:x0 + nw] = np.round(np.clip(small.reshape(nh, nw, 3), 0, 1) * 255)
    return out


def _draw_path(sheet: np.ndarray, idx: np.ndarray, thumb: int, colour: tuple, inset: int) -> None:
    """Outline the cells (t, idx[t]) inset px inside their border and join their centres, in place."""
    centres = []
    for t, a in enumerate(np.asarray(idx, dtype=np.int64)):
        x, y = _cell_origin(t, int(a), thumb)
        cv2.rectangle(sheet, (x - 2 + inset, y - 2 + inset), (x + thumb + 1 - inset, y + thumb + 1 - inset),
                      colour, 2)
        centres.append((x + thumb // 2, y + thumb // 2))
    if len(centres) > 1:
        cv2.polylines(sheet, [np.array(centres, np.int32)], False, colour, 2)


def _label(sheet: np.ndarray, text: str, org: tuple[int, int]) -> None:
    """Small black text with its baseline-left at org, in place."""
    cv2.putText(sheet, text, org, cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1, cv2.LINE_AA)


def matrix_contact_sheet(matrix_frames: np.ndarray, alphas: np.ndarray, times: np.ndarray,
                         path_idx: np.ndarray, diagonal_idx: np.ndarray, thumb: int = 96,
                         computed: np.ndarray | None = None) -> np.ndarray:
    """matrix_frames: (T, A, H, W, 4) (memmap ok) -> (h, w, 3) float32 grid, columns = t, rows = alpha (top 0).

    The optimal path's cells are outlined and joined in red, the diagonal's in
    blue, drawn just inside the red outline so both show where they coincide.
    Cells that `computed` ((T, A) bool, None: all) marks as not computed stay
    background grey with a cross.
    """
    n_t, n_a = matrix_frames.shape[:2]
    if len(alphas) != n_a or len(times) != n_t or len(path_idx) != n_t or len(diagonal_idx) != n_t:
        raise ValueError("alphas, times, path_idx and diagonal_idx must match matrix_frames (T, A, ...)")
    # Drawn in 8 bit: OpenCV's text rendering only supports uint8 images.
    sheet = np.full(contact_sheet_shape(n_t, n_a, thumb), SHEET_GREY, np.uint8)
    for t in range(n_t):  # cell by cell so a memmap is read one frame at a time
        for a in range(n_a):
            x, y = _cell_origin(t, a, thumb)
            if computed is None or computed[t, a]:
                sheet[y:y + thumb, x:x + thumb] = _thumbnail(np.asarray(matrix_frames[t, a]), thumb)
            else:  # a cell no path takes: never blended
                cv2.line(sheet, (x + thumb // 3, y + thumb // 3), (x + 2 * thumb // 3, y + 2 * thumb // 3), (160,) * 3, 1)
                cv2.line(sheet, (x + 2 * thumb // 3, y + thumb // 3), (x + thumb // 3, y + 2 * thumb // 3), (160,) * 3, 1)
    for t in range(n_t):
        _label(sheet, f"t={times[t]:.2f}", (_cell_origin(t, 0, thumb)[0], SHEET_TOP - 6))
    for a in range(n_a):
        _label(sheet, f"a={alphas[a]:.3f}", (2, _cell_origin(0, a, thumb)[1] + thumb // 2 + 4))
    _draw_path(sheet, diagonal_idx, thumb, DIAGONAL_COLOUR, inset=4)
    _draw_path(sheet, path_idx, thumb, PATH_COLOUR, inset=0)
    return sheet.astype(np.float32) / 255.0


def output_row(frames: np.ndarray, thumb: int = 96,
               marks: list[tuple[np.ndarray, tuple[float, float, float]]] = ()) -> np.ndarray:
    """frames: (T, H, W, 4) the segment's output -> (thumb + 2 SHEET_PAD, width, 3) float32 band to put under
    matrix_contact_sheet's grid (the same width and columns), labelled "out". marks: ((T, H, W) weights in [0, 1]
    or bool, (r, g, b) in [0, 1]): each pixel tinted toward that colour by MARK_TINT times twice its weight (the
    full tint from a weight of one half): what the output took from elsewhere than the path's cell."""
    n_t = len(frames)
    band = np.full((thumb + 2 * SHEET_PAD, contact_sheet_shape(n_t, 1, thumb)[1], 3), SHEET_GREY, np.uint8)
    for t in range(n_t):
        rgba = to_rgba(np.asarray(frames[t], np.float32)).copy()
        for weights, colour in marks:
            k = MARK_TINT * np.minimum(2.0 * np.asarray(weights[t], np.float32), 1.0)[..., None]
            rgba[..., :3] = (1.0 - k) * rgba[..., :3] + k * np.asarray(colour, np.float32)
            rgba[..., 3:] = np.maximum(rgba[..., 3:], k)  # a tint on paper shows too
        x = _cell_origin(t, 0, thumb)[0]
        band[SHEET_PAD:SHEET_PAD + thumb, x:x + thumb] = _thumbnail(rgba, thumb)
    _label(band, "out", (2, SHEET_PAD + thumb // 2 + 4))
    return band.astype(np.float32) / 255.0
