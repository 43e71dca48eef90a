"""Output writers: the in-between frames, a preview video, and the matrix contact sheet (§5.2).

Frames follow SHOT_FORMAT.md: OUT_DIR/frames/0000.png ... one 8-bit straight-
alpha RGBA PNG per output time (optionally OUT_DIR/frames_exr/0000.exr in
half float). Every file is written atomically (temp file + rename), so a
crashed run never leaves a truncated frame behind.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import cv2
import numpy as np

from .image_io import composite_over_white, to_rgba, write_image

PATH_COLOUR = (255, 0, 0)           # RGB 8-bit: the optimal path
DIAGONAL_COLOUR = (0, 90, 255)      # RGB 8-bit: the naive alpha = t path
SHEET_PAD = 6                       # pixels between thumbnails and around the grid
SHEET_LEFT = 56                     # label column for alpha
SHEET_TOP = 22                      # label row for t
SHEET_GREY = 237                    # 8-bit background between thumbnails


def select_frames(matrix_frames: np.ndarray, alpha_index: np.ndarray) -> np.ndarray:
    """matrix_frames: (T, A, H, W, 4) (memmap ok), alpha_index: (T,) -> (T, H, W, 4) float32 frames on the path."""
    idx = np.asarray(alpha_index, dtype=np.int64)
    if idx.shape != (matrix_frames.shape[0],):
        raise ValueError(f"alpha_index {idx.shape} must be (T,) = ({matrix_frames.shape[0]},)")
    # fancy indexing reads only the T chosen cells from a memmap
    return np.asarray(matrix_frames[np.arange(len(idx)), idx], dtype=np.float32)


def write_frames(out_dir: str | Path, frames: np.ndarray, exr: bool = False) -> list[Path]:
    """frames: (T, H, W, 4) float32 straight alpha -> the written PNG paths out_dir/frames/0000.png ..."""
    out_dir = Path(out_dir)
    if frames.ndim != 4 or frames.shape[3] != 4:
        raise ValueError(f"frames must be (T, H, W, 4) RGBA, got {frames.shape}")
    pngs = []
    for i in range(frames.shape[0]):  # one frame at a time: frames may be a memmap
        frame = np.asarray(frames[i], dtype=np.float32)
        pngs.append(write_image(out_dir / "frames" / f"{i:04d}.png", frame, "uint8"))
        if exr:
            write_image(out_dir / "frames_exr" / f"{i:04d}.exr", frame, "half")
    return pngs


def _video_frames(frames: np.ndarray, even: bool) -> list[np.ndarray]:
    """(T, H, W, 4) -> list of (H', W', 3) uint8 over white; H', W' padded to even for H.264."""
    out = []
    for i in range(frames.shape[0]):
        rgb = composite_over_white(to_rgba(np.asarray(frames[i], dtype=np.float32)))
        img = np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)
        if even:
            h, w = img.shape[:2]
            img = np.pad(img, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
        out.append(img)
    return out


def write_preview_video(path: str | Path, frames: np.ndarray, fps: float = 8) -> Path:
    """frames: (T, H, W, 4) -> animated GIF (looping) or, for a .mp4 path, H.264 video; written atomically."""
    import imageio.v2 as imageio  # imported here: only the writer needs it

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    mp4 = path.suffix.lower() == ".mp4"
    images = _video_frames(frames, even=mp4)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    os.close(fd)
    try:
        if mp4:
            imageio.mimwrite(tmp, images, format="FFMPEG", fps=fps, macro_block_size=1)
        else:
            # Pillow merges identical consecutive frames (summing their durations), so a
            # static stretch plays for the right time but counts as one GIF frame.
            imageio.mimwrite(tmp, images, format="GIF", duration=1000.0 / fps, loop=0)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


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
                         path_idx: np.ndarray, diagonal_idx: np.ndarray, thumb: int = 96) -> np.ndarray:
    """matrix_frames: (T, A, H, W, 4) (memmap ok) -> (h, w, 3) float32 grid, columns = t, rows = alpha (top 0).

    The optimal path's cells are outlined and joined in red, the diagonal's in
    blue, drawn just inside the red outline so both show where they coincide.
    """
    n_t, n_a = matrix_frames.shape[:2]
    if len(alphas) != n_a or len(times) != n_t or len(path_idx) != n_t or len(diagonal_idx) != n_t:
        raise ValueError("alphas, times, path_idx and diagonal_idx must match matrix_frames (T, A, ...)")
    # Drawn in 8 bit: OpenCV's text rendering only supports uint8 images.
    sheet = np.full(contact_sheet_shape(n_t, n_a, thumb), SHEET_GREY, np.uint8)
    for t in range(n_t):  # cell by cell so a memmap is read one frame at a time
        for a in range(n_a):
            x, y = _cell_origin(t, a, thumb)
            sheet[y:y + thumb, x:x + thumb] = _thumbnail(np.asarray(matrix_frames[t, a]), thumb)
    for t in range(n_t):
        _label(sheet, f"t={times[t]:.2f}", (_cell_origin(t, 0, thumb)[0], SHEET_TOP - 6))
    for a in range(n_a):
        _label(sheet, f"a={alphas[a]:.3f}", (2, _cell_origin(0, a, thumb)[1] + thumb // 2 + 4))
    _draw_path(sheet, diagonal_idx, thumb, DIAGONAL_COLOUR, inset=4)
    _draw_path(sheet, path_idx, thumb, PATH_COLOUR, inset=0)
    return sheet.astype(np.float32) / 255.0
