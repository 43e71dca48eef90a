"""Small preview images of the pipeline stages for the Dagster UI.

Every preview is float32 RGB (h, w, 3) in [0, 1], at most about MAX_WIDTH
pixels wide. Drawing happens in 8 bit (OpenCV's text and anti-aliasing need
uint8) with plain 8-connected lines, so colours at known pixels are exact.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ops.shotio.image_io import composite_over_white, to_rgba, write_image

MAX_WIDTH = 512
MIN_THUMB = 64             # frame strips keep thumbnails at least this wide, even with many frames
FG_TINT = (120, 200, 120)  # RGB 8-bit: foreground wash
FG_WEIGHT = 0.3
OCC_WEIGHT = 0.55
# tab10 without red (handles, points) and grey (front layer): one colour per region / pocket layer
PALETTE = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (148, 103, 189),
           (23, 190, 207), (188, 189, 34), (227, 119, 194), (140, 86, 75)]
POINT_COLOUR = (214, 39, 40)
SLIT_COLOUR = (255, 200, 0)  # the contacts' slits: where the template is cut apart
HANDLE_COLOUR = (214, 39, 40)
FRONT_COLOUR = (50, 50, 50)
POCKET_OFFSET = 2.0        # preview pixels each pocket layer's wireframe is shifted down-right
SUBPIXEL_BITS = 2          # cv2 fixed-point shift for line endpoints


def region_colour(i: int) -> tuple[int, int, int]:
    """8-bit RGB colour of occlusion region / pocket layer i (cycles through PALETTE)."""
    return PALETTE[i % len(PALETTE)]


def _rgb(image: np.ndarray) -> np.ndarray:
    """Any (H, W[, C]) image -> (H, W, 3) float32 over white."""
    return composite_over_white(to_rgba(image)).astype(np.float32)


def _fit_scale(width: int, max_width: int = MAX_WIDTH) -> float:
    """Downscale factor (<= 1) that brings a width to at most max_width."""
    return min(1.0, max_width / max(width, 1))


def _resize(img: np.ndarray, scale: float) -> np.ndarray:
    """(H, W, C) -> resized by scale (area filter when shrinking); C kept."""
    if scale == 1.0:
        return img
    h, w = img.shape[:2]
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    out = cv2.resize(img, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    return out.reshape(size[1], size[0], *img.shape[2:])


def _to_u8(img: np.ndarray) -> np.ndarray:
    """float [0, 1] -> contiguous uint8."""
    return np.ascontiguousarray(np.round(np.clip(img, 0.0, 1.0) * 255.0).astype(np.uint8))


def _to_float(img: np.ndarray) -> np.ndarray:
    """uint8 -> float32 [0, 1]."""
    return img.astype(np.float32) / 255.0


def _fixed(points: np.ndarray, scale: float, offset: float = 0.0) -> np.ndarray:
    """(k, 2) pixel coordinates -> int32 fixed-point coordinates for cv2 with SUBPIXEL_BITS."""
    return np.round((np.asarray(points, np.float64) * scale + offset) * (1 << SUBPIXEL_BITS)).astype(np.int32)


def mask_overlay(drawing: np.ndarray, foreground: np.ndarray, occlusion: list[np.ndarray],
                 boundaries: list[np.ndarray] | None = None,
                 points: list[np.ndarray] | None = None, slits: list[np.ndarray] | None = None) -> np.ndarray:
    """drawing (H, W, C), foreground (H, W) bool, occlusion [(H, W) bool], boundaries [(n, 2)], points [(k, 2)],
    slits [(n, 2) open polylines] -> (h, w, 3) float32: foreground tinted, region i in region_colour(i),
    boundaries, T-junction circles, slits in SLIT_COLOUR."""
    rgb = _rgb(drawing)
    fg = np.asarray(foreground, bool)[..., None]
    rgb = np.where(fg, (1 - FG_WEIGHT) * rgb + FG_WEIGHT * np.float32(FG_TINT) / 255, rgb)
    for i, occ in enumerate(occlusion):
        colour = np.float32(region_colour(i)) / 255
        rgb = np.where(np.asarray(occ, bool)[..., None], (1 - OCC_WEIGHT) * rgb + OCC_WEIGHT * colour, rgb)
    scale = _fit_scale(rgb.shape[1])
    img = _to_u8(_resize(rgb, scale))
    for i, line in enumerate(boundaries or []):
        if len(line) >= 2:
            dark = tuple(int(c * 0.6) for c in region_colour(i))
            cv2.polylines(img, [_fixed(line, scale)], True, dark, 1, cv2.LINE_8, SUBPIXEL_BITS)
    for line in slits or []:
        cv2.polylines(img, [_fixed(line, scale)], False, SLIT_COLOUR, 2, cv2.LINE_8, SUBPIXEL_BITS)
    for pts in points or []:
        for p in _fixed(np.asarray(pts).reshape(-1, 2), scale):
            cv2.circle(img, (int(p[0]), int(p[1])), 4 << SUBPIXEL_BITS, POINT_COLOUR, 2, cv2.LINE_8,
                       SUBPIXEL_BITS)
    return _to_float(img)


def _layer_edges(F: np.ndarray) -> np.ndarray:
    """(m, 3) faces -> (e, 2) unique undirected edges."""
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return np.unique(np.sort(e, axis=1), axis=0)


def wireframe(drawing: np.ndarray, V: np.ndarray, F: np.ndarray, face_layer: np.ndarray,
              handles: np.ndarray | None = None) -> np.ndarray:
    """drawing (H, W, C), V (n, 2) pixels, F (m, 3), face_layer (m,), handles (h,) -> (h, w, 3) float32.

    The front layer is drawn in dark grey; pocket layer l in region_colour(l - 1),
    shifted l * POCKET_OFFSET preview pixels down-right so coincident seams stay visible.
    """
    rgb = 0.5 * _rgb(drawing) + 0.5  # faded so the mesh reads on top of the ink
    scale = _fit_scale(rgb.shape[1])
    img = _to_u8(_resize(rgb, scale))
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    face_layer = np.asarray(face_layer, np.int64)
    for layer in np.unique(face_layer)[::-1]:  # pockets first, the front sheet on top
        edges = _layer_edges(F[face_layer == layer])
        colour = FRONT_COLOUR if layer == 0 else region_colour(int(layer) - 1)
        segs = _fixed(V[edges].reshape(-1, 2), scale, layer * POCKET_OFFSET).reshape(-1, 2, 2)
        cv2.polylines(img, list(segs), False, colour, 1, cv2.LINE_8, SUBPIXEL_BITS)
    if handles is not None:
        for p in _fixed(V[np.asarray(handles, np.int64)], scale):
            cv2.circle(img, (int(p[0]), int(p[1])), 2 << SUBPIXEL_BITS, HANDLE_COLOUR, -1, cv2.LINE_8,
                       SUBPIXEL_BITS)
    return _to_float(img)


def checkerboard(h: int, w: int, square: int = 8) -> np.ndarray:
    """(h, w, 3) float32 light checkerboard (0.8 / 1.0) that shows transparency."""
    y, x = np.mgrid[0:h, 0:w]
    cells = ((y // square + x // square) % 2).astype(np.float32)
    return np.repeat((1.0 - 0.2 * cells)[..., None], 3, axis=2)


def strip_thumb_width(n: int, width: int) -> int:
    """Thumbnail width of a frame strip of n frames of the given width."""
    return min(width, max(MIN_THUMB, MAX_WIDTH // max(n, 1)))


def frame_strip(frames: np.ndarray, max_frames: int = 9,
                marks: list[tuple[np.ndarray, tuple[float, float, float]]] = ()) -> np.ndarray:
    """frames: (T, H, W, 4) -> (h, n * thumb_w, 3) float32, up to max_frames evenly spaced, over a checkerboard.

    marks: ((T, H, W) bool pixels, (r, g, b) in [0, 1]) tinted half-way to that colour, so what a stage
    distrusts (inpainted or torn texture) shows in its preview.
    """
    n_t, h, w = frames.shape[:3]
    idx = np.unique(np.round(np.linspace(0, n_t - 1, min(n_t, max_frames))).astype(np.int64))
    tw = strip_thumb_width(len(idx), w)
    th = max(1, round(h * tw / w))
    board = checkerboard(th, tw)
    thumbs = []
    for i in idx:  # one frame at a time: frames may be a memmap
        rgba = to_rgba(np.asarray(frames[i], np.float32)).copy()
        for pixels, colour in marks:
            hit = np.asarray(pixels[i], bool)
            rgba[hit, :3] = 0.5 * rgba[hit, :3] + 0.5 * np.asarray(colour, np.float32)
        small = cv2.resize(rgba, (tw, th), interpolation=cv2.INTER_AREA)
        a = small[..., 3:4]
        thumbs.append(small[..., :3] * a + board * (1 - a))
    return np.concatenate(thumbs, axis=1).astype(np.float32)


INPAINTED_TINT = (0.15, 0.35, 1.0)  # blue: texture the drawing does not show (§5.1 inpainting)
DISTORTED_TINT = (1.0, 0.1, 0.1)  # red: texture stretched or squashed past the renderer's limit (a tear)
KEYS_TINT = (0.9, 0.1, 0.9)  # magenta: pixels RIFE's interpolation of the keys drew, neither lane being reliable


LABEL_BAND = 18  # pixels above each image in side_by_side
GAP = 4          # pixels between images in side_by_side


def side_by_side(images: list[np.ndarray], labels: list[str]) -> np.ndarray:
    """images: list of (H_i, W_i[, C]) -> (h, w, 3) float32 row at a common height, labels above, w <= MAX_WIDTH."""
    if len(images) != len(labels) or not images:
        raise ValueError("side_by_side needs one label per image and at least one image")
    rgbs = [_rgb(im) for im in images]
    h = max(im.shape[0] for im in rgbs)
    aspect = sum(im.shape[1] / im.shape[0] for im in rgbs)
    # common height so that the row, gaps included, fits MAX_WIDTH
    h = max(8, min(h, int((MAX_WIDTH - GAP * (len(rgbs) - 1)) / aspect)))
    tiles = []
    for im, text in zip(rgbs, labels):
        tile = _resize(im, h / im.shape[0])[:h]
        band = np.full((LABEL_BAND, tile.shape[1], 3), 255, np.uint8)
        cv2.putText(band, text, (2, LABEL_BAND - 5), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
        tiles.append(np.concatenate([_to_float(band), tile], axis=0))
        tiles.append(np.full((h + LABEL_BAND, GAP, 3), 0.85, np.float32))
    return np.concatenate(tiles[:-1], axis=1).astype(np.float32)


def to_png_bytes(img: np.ndarray) -> bytes:
    """(h, w, 3|4) float [0, 1] RGB(A) -> PNG file bytes (8 bit)."""
    u8 = _to_u8(img)
    code = cv2.COLOR_RGBA2BGRA if u8.ndim == 3 and u8.shape[2] == 4 else cv2.COLOR_RGB2BGR
    ok, buf = cv2.imencode(".png", cv2.cvtColor(u8, code) if u8.ndim == 3 else u8)
    if not ok:
        raise OSError("cannot encode preview as PNG")
    return buf.tobytes()


def save_preview(path: str | Path, img: np.ndarray) -> Path:
    """Write a preview (h, w, 3) float32 as an 8-bit PNG, atomically; returns the path."""
    return write_image(path, img, "uint8")
