"""Drawing a posed 3D body (§4.1's training data): camera, depth buffer, hidden-line outlines, fills in a style.

Every body is ray cast (solids.cast) on a supersampled grid; per subpixel the nearest surface is visible.
Outlines are drawn where an artist draws them, read off the depth buffer:
- the silhouette against the paper;
- an occluding contour: two bodies meet in the image and the nearer one does not cover the pixel beside it
  (its own silhouette over the farther one), whatever their depth gap;
- where two bodies interpenetrate (an elbow, a thigh in a round belly) the surfaces meet along a curve with
  no gap: a crease (drawn only in some looks) or, where their materials differ, a material line (a sleeve's
  cuff; some looks draw it).
Lines are centred on the contour, so half a line lies outside the shape, and they belong to the nearer body:
its ground-truth shape takes them in (as the 2D generator's outline polygons do).

The ground truth is exact: per bone, its filled shape (every body on it, hidden parts included) and, per
pixel, the depth where the ray enters it; two bones' shapes overlap where both cover a pixel, and the one
entered first is in front there.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from .bodies3d import Body, Mark
from .looks3d import Look3D
from .paper import make_paper, make_photo, photograph
from .solids import Solid, cast, grid, transformed

SS = 3  # subpixels per pixel side
VIEWS = (("front", 0.3, (-25, 25)), ("three_quarter", 0.32, (25, 65)), ("side", 0.28, (65, 115)),
         ("back_three_quarter", 0.06, (115, 155)), ("back", 0.04, (155, 205)))
LIGHT = np.array([-0.5, -0.6, -0.63]) / np.linalg.norm([-0.5, -0.6, -0.63])  # toward the light: up, left, front


@dataclass
class Camera:
    """An orthographic camera: rot (3, 3) rows = image right, image down, depth (into the page) in world axes."""

    rot: np.ndarray
    yaw: float
    pitch: float
    view: str


def make_camera(rng: np.random.Generator, view: str | None = None) -> Camera:
    """A random view: front, three-quarter, side, or (rarely) from behind; either side; tilted a little. `view`
    (a VIEWS name) fixes the kind of view and leaves the rest random (the same draws either way)."""
    names, probs, ranges = zip(*VIEWS)
    k = int(rng.choice(len(VIEWS), p=np.asarray(probs) / sum(probs)))
    if view is not None:
        if view not in names:
            raise ValueError(f"view {view!r}: use one of {names}")
        k = names.index(view)
    yaw = float(rng.uniform(*ranges[k])) * (1 if rng.random() < 0.5 else -1)
    pitch, roll = float(rng.normal(0, 8)), float(rng.normal(0, 4))
    front = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])  # the character faces the camera
    y, p, r = (math.radians(v) for v in (yaw, pitch, roll))
    turn = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    tilt = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    spin = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
    return Camera(spin @ tilt @ front @ turn, yaw, pitch, names[k])


def fit_to_frame(solids: list[Solid], rot: np.ndarray, size: tuple[int, int], rng: np.random.Generator,
                 fill: tuple, jitter: tuple) -> tuple[float, np.ndarray] | None:
    """Scale k and shift (3,) that fit the rotated solids' extent to a random `fill` share of the (H, W) frame,
    placed at a random `jitter` share of the room left; None when the extent is degenerate."""
    unit = [transformed(s, rot, 1.0, np.zeros(3)) for s in solids]
    lo = np.min([s.extent()[0] for s in unit], axis=0)
    hi = np.max([s.extent()[1] for s in unit], axis=0)
    span = hi - lo
    if np.any(span < 1e-6):
        return None
    h, w = size
    k = float(rng.uniform(*fill)) * min((w - 8) / span[0], (h - 8) / span[1])
    room = np.array([w, h]) - k * span
    offset = np.array([rng.uniform(*jitter), rng.uniform(*jitter)]) * room - k * lo
    return k, np.array([offset[0], offset[1], 200.0])  # depth 200 keeps depths positive: only their order matters


def on_camera(body: Body, camera: Camera, size: tuple[int, int], rng: np.random.Generator, fill: tuple = (0.55, 0.85)
              ) -> tuple[list[Solid], list[Mark], np.ndarray, Callable] | None:
    """The body's solids, marks and (J, 3) joints in camera pixels (x, y, depth), scaled so that it fills a
    random 55-85% of the (H, W) frame, placed with some jitter; and the projection ((n, 3) world points ->
    (n, 3) camera pixels). None when its shape is degenerate."""
    rot = camera.rot
    fit = fit_to_frame(body.solids, rot, size, rng, fill, (0.3, 0.7))
    if fit is None:
        return None
    k, shift = fit
    solids = [transformed(s, rot, k, shift) for s in body.solids]
    marks = [Mark(m.kind, k * m.points @ rot.T + shift, m.width * k, m.solid) for m in body.marks]
    project = lambda p: k * np.asarray(p, np.float64) @ rot.T + shift  # noqa: E731
    return solids, marks, project(body.pose), project


@dataclass(frozen=True)
class Rewobble:
    """The shaky hand of a redrawn key: the look's own wobble field turned by `angle` (radians) toward another,
    independent one (gx, gy: (H, W) float32, about [-1, 1]); amplitude px. Angle 0 is the look's field, pi / 2
    the other one; the cos / sin mix keeps the field's strength in between."""

    amplitude: float
    angle: float
    gx: np.ndarray
    gy: np.ndarray


@dataclass
class Rendered:
    """rgb (H, W, 3) uint8 as a reader decodes it; coverage (H, W) float32 of the character (lines included);
    cover: {bone: (H, W) bool filled shape}; entry: {bone: (H, W) float32 depth where the ray first enters
    one of its bodies, inf where none}. Bones are keyed as the solids name them."""

    rgb: np.ndarray
    coverage: np.ndarray
    cover: dict
    entry: dict


def smooth_noise(rng: np.random.Generator, shape: tuple[int, int], sigma: float) -> np.ndarray:
    """(H, W) float32 Gaussian noise low-passed by `sigma` px, scaled to about [-1, 1]."""
    n = cv2.GaussianBlur(rng.standard_normal(shape).astype(np.float32), (0, 0), max(sigma, 0.3))
    return n / max(float(np.abs(n).max()), 1e-6)


def _up(img: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """An (H, W[, C]) map on the subpixel grid (h2, w2), bilinear."""
    return cv2.resize(img, (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR)


def render(solids: list[Solid], marks: list[Mark], size: tuple[int, int], look: Look3D, seed: int,
           rewobble: Rewobble | None = None) -> Rendered:
    """Draw camera-space solids and marks at `size` (H, W) in `look`; the exact per-bone shapes and depths.
    rewobble: a redrawn key's shaky hand in place of the look's (None: the look's)."""
    rng = np.random.default_rng([seed, 31])
    h, w = size
    h2, w2 = h * SS, w * SS
    best = np.full((h2, w2), np.inf, np.float32)
    vid = np.full((h2, w2), -1, np.int32)
    crops: list = []
    for i, s in enumerate(solids):
        lo, hi = s.extent()
        x0, y0 = max(int(math.floor(lo[0])) - 1, 0), max(int(math.floor(lo[1])) - 1, 0)
        x1, y1 = min(int(math.ceil(hi[0])) + 2, w), min(int(math.ceil(hi[1])) + 2, h)
        if x1 <= x0 or y1 <= y0:
            crops.append(None)
            continue
        xs, ys = grid(x0 + 0.5 / SS - 0.5, y0 + 0.5 / SS - 0.5, (x1 - x0) * SS, (y1 - y0) * SS, 1.0 / SS)
        ent, ext = cast(s, xs, ys)
        ent, ext = ent.astype(np.float32), ext.astype(np.float32)
        crops.append((y0 * SS, x0 * SS, ent, ext))
        sl = (slice(y0 * SS, y1 * SS), slice(x0 * SS, x1 * SS))
        closer = ent < best[sl]
        best[sl] = np.where(closer, ent, best[sl])
        vid[sl] = np.where(closer, i, vid[sl])
    inside = vid >= 0
    patch = _patches(solids, best, vid)
    colours = np.array([look.palette.get(s.material, (0.8, 0.8, 0.8)) for s in solids] + [(1.0, 1.0, 1.0)], np.float32)
    patch_rgb = np.array([look.palette.get(s.patch[2], (0.9, 0.9, 0.9)) if s.patch else (1, 1, 1) for s in solids]
                         + [(1.0, 1.0, 1.0)], np.float32)
    edges = _edges(solids, crops, best, vid, patch)
    seeds, owner, pool = _seeds(edges, look, rng, (h2, w2))

    paper = make_paper(look.paper, size, seed)
    paper_rgb, grain = _up(paper.rgb, (h2, w2)), _up(paper.grain, (h2, w2))
    col = np.where(patch[..., None], patch_rgb[vid], colours[vid])
    if look.shading != "none":
        col = col * _shade(best, vid, look.shading)[..., None]
    canvas = _fill(look, paper_rgb, grain, col, inside, pool, rng)
    band = np.zeros((h2, w2), bool)
    band_owner = np.full((h2, w2), -1, np.int32)
    if look.line != "none" and seeds.any():
        band, band_owner, alpha = _lines(look, seeds, owner, grain, rng, (h, w))
        if look.line == "shade":
            lc = 0.45 * colours[np.maximum(band_owner, 0)]
        else:
            lc = np.broadcast_to(np.asarray(look.line_rgb, np.float32), canvas.shape)
        canvas = canvas * (1 - alpha[..., None]) + lc * alpha[..., None]
    if look.marks and marks:
        am = _marks(marks, solids, best, vid, (h2, w2))
        fixed = look.line in ("fixed", "crayon", "graphite") and look.fill in ("paper", "wax")
        mc = np.broadcast_to(np.asarray(look.line_rgb, np.float32), canvas.shape) if fixed else 0.5 * col
        canvas = canvas * (1 - am[..., None]) + mc * am[..., None]

    rgb = cv2.resize(np.clip(canvas, 0, 1).astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
    coverage = cv2.resize((inside | band).astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
    cover, entry = _bone_truth(solids, crops, band, band_owner, (h, w))
    if look.blur > 0:
        rgb = cv2.GaussianBlur(rgb, (0, 0), look.blur)
        coverage = cv2.GaussianBlur(coverage, (0, 0), look.blur)
    if look.wobble > 0 or rewobble is not None:
        rgb, coverage, cover, entry = _wobble(rng, look.wobble, rgb, coverage, cover, entry, rewobble)
    if look.photo:
        rgb8, _ = photograph(rgb, make_photo(size, seed))
    else:
        rgb8 = np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)
    return Rendered(rgb8, np.clip(coverage, 0, 1), cover, entry)


def _patches(solids: list[Solid], best: np.ndarray, vid: np.ndarray) -> np.ndarray:
    """(h2, w2) bool subpixels showing an ellipsoid's patch (a pale belly): the visible point's direction in the
    ellipsoid's own axes lies within the patch's cap."""
    out = np.zeros(vid.shape, bool)
    for i, s in enumerate(solids):
        if s.patch is None or s.kind != "ellipsoid":
            continue
        ys, xs = np.nonzero(vid == i)
        if not len(ys):
            continue
        p = np.stack([(xs + 0.5) / SS - 0.5, (ys + 0.5) / SS - 0.5, best[ys, xs]], 1) - s.centre
        local = p @ s.axes.T
        if s.egg:  # each half of an egg has its own first radius
            local[:, 0] /= np.where(local[:, 0] >= 0, 1 + s.egg, 1 - s.egg)
        local = local / s.radii
        local /= np.maximum(np.linalg.norm(local, axis=1, keepdims=True), 1e-9)
        hit = local @ s.patch[0] > s.patch[1]
        out[ys[hit], xs[hit]] = True
    return out


def _covers(crops: list, solid: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """(n,) bool: does solid[k] cover subpixel (rows[k], cols[k])."""
    out = np.zeros(len(solid), bool)
    for s in np.unique(solid):
        if crops[s] is None:
            continue
        y0, x0, ent, _ = crops[s]
        k = np.nonzero(solid == s)[0]
        r, c = rows[k] - y0, cols[k] - x0
        ok = (r >= 0) & (r < ent.shape[0]) & (c >= 0) & (c < ent.shape[1])
        hit = np.zeros(len(k), bool)
        hit[ok] = np.isfinite(ent[r[ok], c[ok]])
        out[k] = hit
    return out


def _edges(solids: list[Solid], crops: list, best: np.ndarray, vid: np.ndarray, patch: np.ndarray) -> dict:
    """Neighbouring subpixel pairs that show different surfaces, by kind: {'silhouette' | 'occluding' | 'material'
    | 'crease': (rows_p, cols_p, rows_q, cols_q, owner)}; owner = the solid the line belongs to (the nearer)."""
    label = np.where(vid >= 0, vid * 2 + patch, -1)
    bone = np.array([s.bone for s in solids] + [-1])
    mat = np.array([s.material for s in solids] + [""])
    found: dict[str, list] = {k: [] for k in ("silhouette", "occluding", "material", "crease")}
    for dy, dx in ((0, 1), (1, 0)):
        a, b = label[: label.shape[0] - dy, : label.shape[1] - dx], label[dy:, dx:]
        rp, cp = np.nonzero(a != b)
        rq, cq = rp + dy, cp + dx
        va, vb = vid[rp, cp], vid[rq, cq]
        sil = (va < 0) | (vb < 0)
        same = (va == vb) & ~sil
        da, db = best[rp, cp], best[rq, cq]
        a_near = da <= db
        near = np.where(a_near, va, vb)
        far = np.where(a_near, vb, va)
        orow, ocol = np.where(a_near, rq, rp), np.where(a_near, cq, cp)
        test = ~sil & ~same
        covers = np.zeros(len(rp), bool)
        covers[test] = _covers(crops, near[test], orow[test], ocol[test])
        occluding = test & ~covers
        fused = test & covers
        differ = mat[np.maximum(near, 0)] != mat[np.maximum(far, 0)]
        material = same | (fused & differ)
        crease = fused & ~differ & (bone[np.maximum(near, 0)] != bone[np.maximum(far, 0)])
        owner = np.where(sil, np.maximum(va, vb), near)
        for kind, sel in (("silhouette", sil), ("occluding", occluding), ("material", material), ("crease", crease)):
            found[kind].append((rp[sel], cp[sel], rq[sel], cq[sel], owner[sel]))
    return {k: tuple(np.concatenate([v[i] for v in vs]) for i in range(5)) for k, vs in found.items()}


def _seeds(edges: dict, look: Look3D, rng: np.random.Generator, shape: tuple[int, int]
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(h2, w2) bool subpixels on a drawn line's contour, (h2, w2) int32 the solid each belongs to, and
    (h2, w2) float32 watercolour pooling near the wash's own edges."""
    seeds = np.zeros(shape, bool)
    owner = np.full(shape, -1, np.int32)
    kinds = ["silhouette", "occluding"] + (["material"] if look.material_lines else []) \
        + (["crease"] if look.crease else [])
    for k in kinds:
        rp, cp, rq, cq, o = edges[k]
        for r, c in ((rp, cp), (rq, cq)):
            seeds[r, c] = True
            owner[r, c] = o
    pool = np.zeros(shape, np.float32)
    if look.fill == "wash":
        rims = np.zeros(shape, np.uint8)
        for k in ("silhouette", "occluding", "material") + (("crease",) if rng.random() < 0.5 else ()):
            rp, cp, rq, cq, _ = edges[k]
            rims[rp, cp] = rims[rq, cq] = 1
        d = cv2.distanceTransform(1 - rims, cv2.DIST_L2, 5)
        pool = np.exp(-d / (1.8 * SS)).astype(np.float32)
    return seeds, owner, pool


def _lines(look: Look3D, seeds: np.ndarray, owner: np.ndarray, grain: np.ndarray, rng: np.random.Generator,
           size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The outline band (h2, w2) bool, the solid owning each band subpixel, and the line's (h2, w2) alpha:
    width varying along the line, gaps, pencil pressure, the paper's tooth under graphite and crayon."""
    shape = seeds.shape
    dist, lab = cv2.distanceTransformWithLabels((~seeds).astype(np.uint8), cv2.DIST_L2, 5,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    sr, sc = np.nonzero(seeds)  # labels number the seed subpixels in scan order
    band_owner = owner[sr, sc][np.maximum(lab, 1) - 1]
    width = _up(smooth_noise(rng, size, 6.0), shape)
    half = 0.5 * SS * look.line_width * (1 + look.width_var * width)
    band = dist <= np.maximum(half - 0.5, 0.35 * SS)
    alpha = band.astype(np.float32)
    if look.breaks > 0:
        gaps = _up(smooth_noise(rng, size, 3.0), shape)
        cut = np.quantile(gaps[band], look.breaks) if band.any() else -1.0
        alpha *= np.clip((gaps - cut) / 0.12, 0, 1)
    if look.line == "graphite":
        pressure = _up(smooth_noise(rng, size, 10.0), shape)
        alpha *= np.clip(0.7 + 0.25 * pressure + 0.3 * grain, 0.25, 1.0)
    if look.line == "crayon":
        alpha *= np.clip(0.8 + 0.35 * grain, 0.3, 1.0)  # wax skips the paper's tooth here and there
    band_owner = np.where(band, band_owner, -1)
    return band, band_owner, alpha


def _shade(best: np.ndarray, vid: np.ndarray, kind: str) -> np.ndarray:
    """(h2, w2) float32 brightness factor from the visible surface's normal (from the depth's slope)."""
    z = np.where(np.isfinite(best), best, 0.0).astype(np.float32)
    gx, gy = np.zeros_like(z), np.zeros_like(z)
    same_x = vid[:, 1:] == vid[:, :-1]
    same_y = vid[1:] == vid[:-1]
    gx[:, :-1] = np.where(same_x, (z[:, 1:] - z[:, :-1]) * SS, 0)
    gy[:-1] = np.where(same_y, (z[1:] - z[:-1]) * SS, 0)
    gx, gy = np.clip(gx, -8, 8), np.clip(gy, -8, 8)
    n = np.stack([gx, gy, -np.ones_like(z)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    lit = n @ LIGHT.astype(np.float32)
    if kind == "cel":
        return np.where(lit < 0.3, 0.74, 1.0).astype(np.float32)
    return (0.68 + 0.45 * np.clip(lit, 0, 1)).astype(np.float32)


def _fill(look: Look3D, paper: np.ndarray, grain: np.ndarray, col: np.ndarray, inside: np.ndarray, pool: np.ndarray,
          rng: np.random.Generator) -> np.ndarray:
    """(h2, w2, 3) the paper with the bodies' fills: paper (line art), flat, watercolour wash, or waxy crayon."""
    canvas = paper.copy()
    if look.fill == "flat":
        canvas[inside] = col[inside]
    elif look.fill == "wash":
        blot = _up(smooth_noise(rng, (paper.shape[0] // SS, paper.shape[1] // SS), 5.0), paper.shape[:2])
        density = (1 + 0.1 * blot) * (1 + 0.12 * grain) * (1 + 0.75 * pool)
        wash = paper * np.power(np.maximum(col, 1e-3), density[..., None])
        canvas[inside] = wash[inside]
    elif look.fill == "wax":
        h2, w2 = inside.shape
        streak = cv2.GaussianBlur(rng.standard_normal((h2, w2)).astype(np.float32), (0, 0), sigmaX=7.0, sigmaY=0.8)
        m = cv2.getRotationMatrix2D((w2 / 2, h2 / 2), float(rng.uniform(0, 180)), 1.0)
        streak = cv2.warpAffine(streak, m, (w2, h2), borderMode=cv2.BORDER_REFLECT)
        streak /= max(float(np.abs(streak).max()), 1e-6)
        a = np.clip(0.6 + 0.45 * streak + 0.12 * grain, 0.2, 0.95)[..., None]
        canvas = np.where(inside[..., None], paper * (1 - a) + col * a, canvas)
    return canvas


def _marks(marks: list[Mark], solids: list[Solid], best: np.ndarray, vid: np.ndarray, shape: tuple[int, int]
           ) -> np.ndarray:
    """(h2, w2) float32 alpha of the texture marks, each drawn where its own surface is the visible one."""
    img = np.zeros(shape, np.uint8)
    shift = 3
    bone = [s.bone for s in solids]
    for m in marks:
        pts = m.points
        col = np.round((pts[:, 0] + 0.5) * SS - 0.5).astype(int)
        row = np.round((pts[:, 1] + 0.5) * SS - 0.5).astype(int)
        ok = (row >= 0) & (row < shape[0]) & (col >= 0) & (col < shape[1])
        seen = np.zeros(len(pts), bool)
        v = vid[row[ok], col[ok]]
        near = np.abs(best[row[ok], col[ok]] - pts[ok, 2]) < 0.8 + 0.15 * max(m.width, 1.0)
        seen[ok] = near & (v >= 0) & (np.asarray(bone)[np.maximum(v, 0)] == bone[m.solid])
        fixed = np.round(np.stack([(pts[:, 0] + 0.5) * SS - 0.5, (pts[:, 1] + 0.5) * SS - 0.5], 1) * (1 << shift))
        fixed = fixed.astype(np.int32)
        thick = max(1, int(round(m.width * SS)))
        if m.kind == "spot":
            if seen[0]:
                cv2.circle(img, tuple(int(v) for v in fixed[0]), int(round(m.width * SS * (1 << shift))), 255, -1,
                           cv2.LINE_AA, shift)
            continue
        run: list = []
        for k in range(len(pts)):
            if seen[k]:
                run.append(fixed[k])
            if (not seen[k] or k == len(pts) - 1) and len(run) >= 2:
                cv2.polylines(img, [np.array(run)], False, 255, thick, cv2.LINE_AA, shift)
            if not seen[k]:
                run = []
    return img.astype(np.float32) / 255.0


def _bone_truth(solids: list[Solid], crops: list, band: np.ndarray, band_owner: np.ndarray, size: tuple[int, int]
                ) -> tuple[dict, dict]:
    """Per bone, its (H, W) bool filled shape (its bodies, hidden parts included, and its half of its lines)
    and (H, W) float32 entry depth (the nearest over each pixel's subpixels; inf where none)."""
    h, w = size
    hits: dict[int, np.ndarray] = {}
    entry: dict[int, np.ndarray] = {}
    for i, s in enumerate(solids):
        if crops[i] is None:
            continue
        y0, x0, ent, _ = crops[i]
        hit = hits.setdefault(s.bone, np.zeros((h * SS, w * SS), bool))
        sl = (slice(y0, y0 + ent.shape[0]), slice(x0, x0 + ent.shape[1]))
        hit[sl] |= np.isfinite(ent)
        e = entry.setdefault(s.bone, np.full((h, w), np.inf, np.float32))
        small = ent.reshape(ent.shape[0] // SS, SS, ent.shape[1] // SS, SS).min(axis=(1, 3))
        esl = (slice(y0 // SS, y0 // SS + small.shape[0]), slice(x0 // SS, x0 // SS + small.shape[1]))
        e[esl] = np.minimum(e[esl], small)
    bone_of = np.array([s.bone for s in solids] + [-1])
    cover = {}
    for b, hit in hits.items():
        mine = band & (bone_of[band_owner] == b)
        area = cv2.resize((hit | mine).astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
        cover[b] = area > 0.5
    return cover, entry


def _wobble(rng: np.random.Generator, amount: float, rgb: np.ndarray, coverage: np.ndarray, cover: dict,
            entry: dict, rewobble: Rewobble | None = None) -> tuple:
    """A shaky hand: the drawing and its truth displaced by one smooth field of about `amount` px (a redrawn
    key's: its own amplitude, the field turned toward another)."""
    h, w = coverage.shape
    fx = smooth_noise(rng, (h, w), 14.0)
    fy = smooth_noise(rng, (h, w), 14.0)
    if rewobble is not None:
        c, s = math.cos(rewobble.angle), math.sin(rewobble.angle)
        fx, fy, amount = c * fx + s * rewobble.gx, c * fy + s * rewobble.gy, rewobble.amplitude
    dx = fx * amount
    dy = fy * amount
    gx, gy = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    mx, my = gx + dx, gy + dy
    lin = lambda a: cv2.remap(a, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)  # noqa: E731
    near = lambda a: cv2.remap(a, mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)  # noqa: E731
    cover = {b: near(m.astype(np.uint8)) > 0 for b, m in cover.items()}
    entry = {b: near(e) for b, e in entry.items()}
    return lin(rgb), lin(coverage), cover, entry
