"""Paint a posed character on paper in a style: per part, back to front, on its bounding box only.

Colours are reflectances in [0, 1]; a part's coverage is supersampled (raster.SS) and area-averaged, so edges
carry fractional coverage. Every random look (edge wobble, pigment blotches, pencil pressure) is drawn from
the character's seed and the bone, so it stays fixed on the part as it moves.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .geometry import part_outline
from .model import Character, Part
from .order import draw_order
from .paper import Paper
from .raster import SS, bone_frame, fill, patch_images, strokes_image
from .styles import Palette, Style

INK_RGB = np.array([0.07, 0.07, 0.09], np.float32)
GRAPHITE_RGB = np.array([0.27, 0.27, 0.3], np.float32)


@dataclass
class Painted:
    """rgb (H, W, 3) float32 reflectance; coverage: per bone (H, W) float32 (zeros if undrawn); union (H, W)."""

    rgb: np.ndarray
    coverage: list[np.ndarray]
    union: np.ndarray


def colour(palette: Palette, material: str) -> tuple[np.ndarray, float]:
    """(3,) float32 reflectance and opacity (0 = transparent wash) of a material."""
    v = palette.get(material, palette.get("body", (200, 200, 200)))
    return np.asarray(v[:3], np.float32) / 255.0, float(v[3]) if len(v) > 3 else 0.0


def line_colour(style: Style, palette: Palette, material: str) -> np.ndarray:
    """(3,) reflectance of a part's outline in this style."""
    if style.line == "ink":
        return INK_RGB
    if style.line == "graphite":
        return GRAPHITE_RGB
    if "outline" in palette:
        return np.asarray(palette["outline"], np.float32) / 255.0
    return colour(palette, material)[0] * 0.45


def _smooth_periodic(param: np.ndarray, rng: np.random.Generator, freqs: tuple[int, ...]) -> np.ndarray:
    """(n,) smooth periodic noise in [-1, 1] along an outline parameter (radians)."""
    out = sum(rng.uniform(0.5, 1.0) * np.sin(f * param + rng.uniform(0, 2 * math.pi)) for f in freqs)
    return out / max(float(np.abs(out).max()), 1e-9)


def _blotches(xy: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(h, w) pigment density variation in about [-1, 1] from bone-frame coordinates xy (h, w, 2) px."""
    out = np.zeros(xy.shape[:2], np.float32)
    for _ in range(5):
        a, lam = rng.uniform(0, 2 * math.pi), rng.uniform(7.0, 26.0)
        k = 2 * math.pi / lam * np.array([math.cos(a), math.sin(a)], np.float32)
        out += np.sin(xy @ k + rng.uniform(0, 2 * math.pi)).astype(np.float32)
    return out / math.sqrt(5 / 2)


def _box(pts: np.ndarray, margin: float, size: tuple[int, int]) -> tuple[int, int, int, int] | None:
    """(x0, y0, x1, y1) integer crop holding pts (n, 2) plus margin px, clipped to the image; None if outside."""
    h, w = size
    x0, y0 = np.floor(pts.min(0) - margin).astype(int)
    x1, y1 = np.ceil(pts.max(0) + margin).astype(int) + 1
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
    return None if x1 <= x0 or y1 <= y0 else (int(x0), int(y0), int(x1), int(y1))


def _down(img: np.ndarray, w: int, h: int) -> np.ndarray:
    """Area-average a supersampled (h*SS, w*SS) canvas to (h, w)."""
    return cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)


def paint(char: Character, pose: np.ndarray, size: tuple[int, int], style: Style, palette: Palette,
          paper: Paper) -> Painted:
    """Paint the character in `pose` (J, 3) on `paper` at `size` (H, W) px."""
    h_img, w_img = size
    canvas = paper.rgb.copy()
    union_ss = np.zeros((h_img * SS, w_img * SS), np.uint8)
    coverage = [np.zeros(size, np.float32) for _ in char.bones]
    interior: dict[int, np.ndarray] = {}  # bone -> (H, W) coverage inside its outline, for joined neighbours
    for i in draw_order(char, pose):
        p, c = char.bones[i]
        part = char.parts[c]
        p0, p1 = pose[p, :2].astype(np.float64), pose[c, :2].astype(np.float64)
        pts, nrm, param = part_outline(part, p0, p1)
        looks = np.random.default_rng([char.seed, c, 7])  # fixed per part: the same edge in every frame
        if style.wobble:
            pts = pts + nrm * (style.wobble * _smooth_periodic(param, looks, (3, 5, 8, 13)))[:, None]
        if style.line != "none":
            ph = char.weight_phase[c]
            width = style.line_width * (1 + 0.16 * np.sin(2 * param + ph[0]) + 0.08 * np.sin(5 * param + ph[1]))
            outer, inner_pts = pts + nrm * (0.5 * width)[:, None], pts - nrm * (0.5 * width)[:, None]
        else:
            outer, inner_pts = pts, None
        box = _box(outer, 2 + 3 * style.soften, size)
        if box is None:
            continue
        x0, y0, x1, y1 = box
        w, h = x1 - x0, y1 - y0
        origin = np.array([x0, y0], np.float64)
        big = (h * SS, w * SS)
        outer_ss = fill(big, outer, origin)
        union_ss[y0 * SS:y1 * SS, x0 * SS:x1 * SS] = np.maximum(union_ss[y0 * SS:y1 * SS, x0 * SS:x1 * SS],
                                                                 np.round(outer_ss * 255).astype(np.uint8))
        cov = _down(outer_ss, w, h)
        if style.soften:
            cov = cv2.GaussianBlur(cov, (0, 0), style.soften)
        inner = _down(fill(big, inner_pts, origin), w, h) if inner_pts is not None else cov
        strokes = char.strokes[c]
        if style.fill == "paper":  # line art outlines the colour patches (hair, belly, boot shaft) instead
            strokes = strokes + [("line", np.vstack([g, g[:1]]), 1.0) for k, g, _ in strokes if k == "patch"]
        tex = _down(strokes_image(big, strokes, p0, p1, part.radius, origin), w, h)
        patches = [(m, _down(a, w, h)) for m, a in patch_images(big, char.strokes[c], p0, p1, part.radius, origin)]
        sl = (slice(y0, y1), slice(x0, x1))
        merged = np.zeros((h, w), np.float32)  # inside already painted parts this one is joined to: one shape
        for j, inside in interior.items():
            if char.joined(i, j):
                merged = np.maximum(merged, inside[sl])
        rgb = _appearance(style, palette, paper, sl, part, cov, inner, tex, patches, p0, p1, pts, param, origin,
                          looks, merged)
        canvas[sl] = canvas[sl] * (1 - cov[..., None]) + rgb * cov[..., None]
        coverage[i][sl] = cov
        interior[i] = np.zeros(size, np.float32)
        interior[i][sl] = inner
    union = _down(union_ss.astype(np.float32) / 255.0, w_img, h_img)
    if style.soften:
        union = cv2.GaussianBlur(union, (0, 0), style.soften)
    return Painted(np.clip(canvas, 0, 1), coverage, union)


def _appearance(style: Style, palette: Palette, paper: Paper, sl: tuple[slice, slice], part: Part,
                cov: np.ndarray, inner: np.ndarray, tex: np.ndarray, patches: list, p0: np.ndarray, p1: np.ndarray,
                pts: np.ndarray, param: np.ndarray, origin: np.ndarray, looks: np.random.Generator,
                merged: np.ndarray) -> np.ndarray:
    """(h, w, 3) reflectance of one part over its crop: fill, outline and texture strokes; no outline inside
    `merged` (h, w), the coverage of the parts it is joined to."""
    base, opacity = colour(palette, part.material)
    col = np.broadcast_to(base, (*cov.shape, 3)).copy()
    opac = np.full(cov.shape, opacity, np.float32)
    for material, a in patches:
        c_patch, o_patch = colour(palette, material)
        col += (c_patch - col) * (a * inner)[..., None]
        opac += (o_patch - opac) * a * inner
    paper_rgb, grain = paper.rgb[sl], paper.grain[sl]
    ring = np.clip(cov - inner, 0, 1) * (1 - merged)
    if style.fill == "paper":
        rgb = paper_rgb.copy()
    elif style.fill == "flat":
        rgb = col
    else:
        rgb = _wash(col, opac, paper_rgb, grain, np.maximum(inner, merged), p0, p1, origin, looks)
    tex_a = tex * inner
    if style.line == "graphite":  # pressure along the stroke and the paper's tooth break the line up
        pressure = _pressure(pts, param, origin, cov.shape, style.line_width, looks)
        tooth = np.clip(0.8 + 0.3 * grain, 0.35, 1.0)
        ring = ring * pressure * tooth
        tex_a = tex_a * 0.7 * tooth
    if style.line != "none":
        rgb += (line_colour(style, palette, part.material) - rgb) * ring[..., None]
    if style.fill == "wash":  # strokes are a denser wash of the local colour
        tex_rgb = paper_rgb * np.power(np.maximum(col, 1e-3), 2.4)
    elif style.fill == "flat":
        tex_rgb = col * 0.62
    else:
        tex_rgb = line_colour(style, palette, part.material)
    return rgb + (tex_rgb - rgb) * tex_a[..., None]


def _wash(col: np.ndarray, opacity: np.ndarray, paper_rgb: np.ndarray, grain: np.ndarray, inner: np.ndarray,
          p0: np.ndarray, p1: np.ndarray, origin: np.ndarray, looks: np.random.Generator) -> np.ndarray:
    """(h, w, 3) watercolour: pigment density varying in blotches, granulating in the paper's tooth, pooling
    darker along the edge of `inner` (h, w: the wash and what it is joined to); opaque materials (white gouache) cover the paper and only grey at the edge."""
    h, w = inner.shape
    d, n = bone_frame(p0, p1)
    u = d / max(float(np.hypot(*d)), 1e-9)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    rel = np.stack([xx + origin[0] - p0[0], yy + origin[1] - p0[1]], -1)
    xy = np.stack([rel @ u.astype(np.float32), rel @ n.astype(np.float32)], -1)  # bone frame: moves with the part
    dist = cv2.distanceTransform((inner > 0.5).astype(np.uint8), cv2.DIST_L2, 3)
    pool = np.exp(-dist / 1.8)
    density = (1 + 0.08 * _blotches(xy, looks)) * (1 + 0.12 * grain) * (1 + 0.75 * pool)
    transparent = paper_rgb * np.power(np.maximum(col, 1e-3), density[..., None])
    if not opacity.any():
        return transparent
    opaque = col * (1 - 0.2 * pool - 0.02 * grain)[..., None]
    return transparent + (opaque - transparent) * opacity[..., None]


def _pressure(pts: np.ndarray, param: np.ndarray, origin: np.ndarray, shape: tuple[int, int], width: float,
              looks: np.random.Generator) -> np.ndarray:
    """(h, w) pencil pressure in [0.35, 1] painted along the outline, looked up by the line's pixels."""
    alpha = np.clip(0.72 + 0.28 * _smooth_periodic(param, looks, (2, 3, 7, 11)), 0.35, 1.0)
    img = np.zeros(shape, np.float32)
    q = np.round((pts - origin) * 16).astype(np.int32)
    thick = int(math.ceil(width)) + 3
    for k in range(len(q)):
        a, b = q[k], q[(k + 1) % len(q)]
        cv2.line(img, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), float(alpha[k]), thick, cv2.LINE_8, 4)
    return img
