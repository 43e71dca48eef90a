"""CPU renderer of a textured 2.5D template (§5.1).

A triangle-id buffer is rasterized back to front by face depth at a
supersampling factor s; every covered sample maps its pixel's centre through
its face's affine map (deformed -> rest) and the textures are sampled with
one cv2.remap each (premultiplied alpha, so edges do not darken); the s x s
samples are then averaged, which anti-aliases the edges between faces and
layers while the template at rest reproduces its texture exactly.

Where the front sheet lies over itself (a slit limb moved across the body,
a cut region over the sheet), a soft edge on top shows the sheet beneath it
rather than the paper: a pale watercolour hand over the skirt stays a hand
over the skirt. Pockets never show through, so at rest the drawing's own
soft edges stay exact.

Supersampling convention: original pixel i covers [i - 0.5, i + 0.5) (the
origin is the top-left pixel's centre), so sample j of the s-times grid has
its centre at original coordinate (j + 0.5) / s - 0.5, i.e. a point x maps
to x_s = (x + 0.5) * s - 0.5. A face covers the samples whose centres lie
inside it or within half a sample of its edges (cv2's inclusive fill), so
shared edges never leave holes and silhouettes grow by at most 0.5 / s px.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ops.appearance.layers import layer_depth, layer_groups
from ops.geometry.mesh import face_stretch
from ops.types import TexturedTemplate

SHIFT = 8  # cv2 fixed-point fraction bits: 1/256 px vertex accuracy
# a face scaled more than this (or squashed below its inverse) no longer shows the drawing as drawn: where a mesh
# glued across an unseen occlusion tears (a hand on the hip as the arm rises), its texture smears
DISTORTION_LIMIT = 2.0
_DEPTH_DECIMALS = 9  # depths equal to this many decimals are ties (bbw rows sum to 1 only up to rounding)


def to_supersampled(X: np.ndarray, scale: int) -> np.ndarray:
    """X: (..., 2) pixels -> (..., 2) coordinates in the scale-times grid (pixel centres at integers)."""
    return (np.asarray(X, dtype=np.float64) + 0.5) * scale - 0.5


def sample_centers(shape: tuple[int, int], scale: int) -> tuple[np.ndarray, np.ndarray]:
    """(H*s, W*s) float64 x and y of every supersample centre, in original pixels."""
    h, w = shape
    xs = (np.arange(w * scale) + 0.5) / scale - 0.5
    ys = (np.arange(h * scale) + 0.5) / scale - 0.5
    return np.meshgrid(xs, ys)


def rasterize_ids(X: np.ndarray, faces: np.ndarray, order: np.ndarray, shape: tuple[int, int],
                  scale: int = 1, origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """X: (n, 2) pixels, faces (m, 3), order (k,) face ids back to front -> (H*s, W*s) int32 face id, -1 empty.

    origin: the (row, column) pixel of the frame that the (H, W) window starts at: the ids are exactly those
    of the same window of a whole-frame rasterization (the shift is whole samples in fixed point)."""
    h, w = shape
    ids = np.full((h * scale, w * scale), -1, dtype=np.int32)
    order = np.asarray(order, dtype=np.int64)
    if order.size == 0:
        return ids
    pts = np.round(to_supersampled(X, scale) * (1 << SHIFT)).astype(np.int64)
    pts -= np.array([origin[1], origin[0]], np.int64) * (scale << SHIFT)
    pts = pts.astype(np.int32)
    tris = pts[np.asarray(faces)[order]]  # (k, 3, 2) fixed point
    # cv2 fills one colour per call, and every face needs its own id, so the loop is per face;
    # a fill is a few microseconds, ~5 ms for 1500 faces.
    for f, tri in zip(order.tolist(), tris):
        cv2.fillConvexPoly(ids, tri, f, lineType=cv2.LINE_8, shift=SHIFT)
    return ids


def affine_maps(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """src, dst: (m, 3, 2) triangles -> (m, 2, 3) affine maps A with dst = A[:, :, :2] @ src + A[:, :, 2]."""
    e = np.stack([src[:, 1] - src[:, 0], src[:, 2] - src[:, 0]], axis=2)  # (m, 2, 2) columns = edges
    r = np.stack([dst[:, 1] - dst[:, 0], dst[:, 2] - dst[:, 0]], axis=2)
    det = e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0]
    ok = np.abs(det) > 1e-12
    safe = np.where(ok, det, 1.0)
    inv = np.stack([np.stack([e[:, 1, 1], -e[:, 0, 1]], 1), np.stack([-e[:, 1, 0], e[:, 0, 0]], 1)], 1)
    inv = inv / safe[:, None, None]
    lin = np.einsum("mij,mjk->mik", r, inv)
    lin[~ok] = 0.0  # a degenerate source triangle collapses onto its first vertex
    trans = dst[:, 0] - np.einsum("mij,mj->mi", lin, src[:, 0])
    return np.concatenate([lin, trans[:, :, None]], axis=2)


def rest_maps(X: np.ndarray, rest: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 2, 3) float32 affine map of every face from its deformed position X (n, 2) back to rest (n, 2)."""
    return affine_maps(np.asarray(X, np.float64)[faces], np.asarray(rest, np.float64)[faces]).astype(np.float32)


def back_map(ids: np.ndarray, A: np.ndarray, scale: int, origin: tuple[int, int] = (0, 0)
             ) -> tuple[np.ndarray, np.ndarray]:
    """ids (H*s, W*s) of a window starting at pixel origin (row, column), A (m, 2, 3) rest_maps -> float32 map_x,
    map_y: for every covered sample, the rest position of its PIXEL's centre under the sample's face (-1e4 where
    empty).

    The supersamples decide which faces cover a pixel and by how much (coverage anti-aliasing); each face
    is read at the pixel centre, so an undeformed template reproduces its texture exactly instead of
    blurring it by the sample spread.
    """
    h, w = ids.shape
    px = (origin[1] + np.arange(w) // scale).astype(np.float32)[None, :]
    py = (origin[0] + np.arange(h) // scale).astype(np.float32)[:, None]
    f = np.maximum(ids, 0)
    # gathers of contiguous per-coefficient arrays in float32: the whole grid costs a few ms
    coef = [np.ascontiguousarray(A[:, i, j]).take(f) for i in range(2) for j in range(3)]
    map_x = coef[0] * px + coef[1] * py + coef[2]
    map_y = coef[3] * px + coef[4] * py + coef[5]
    empty = ids < 0
    map_x[empty] = -1e4
    map_y[empty] = -1e4
    return map_x, map_y


def premultiply(rgba: np.ndarray) -> np.ndarray:
    """(H, W, 4) straight alpha -> (H, W, 4) float32 premultiplied."""
    out = np.array(rgba, dtype=np.float32, copy=True)
    out[..., :3] *= out[..., 3:4]
    return out


def unpremultiply(rgba: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """(H, W, 4) premultiplied -> (H, W, 4) float32 straight alpha (rgb 0 where alpha ~ 0)."""
    out = np.array(rgba, dtype=np.float32, copy=True)
    a = out[..., 3:4]
    out[..., :3] = np.where(a > eps, out[..., :3] / np.maximum(a, eps), 0.0)
    return np.clip(out, 0.0, 1.0)


def depth_order(textured: TexturedTemplate, pose: np.ndarray, groups: np.ndarray | None = None) -> np.ndarray:
    """(m,) face indices back to front: larger depth first; on ties pockets (layer > 0) before the front sheet.

    The faces of each overlapping layer (a region's front-sheet faces, its pocket) share the layer's mean depth
    (ops.appearance.layers), as when texturing chose which of them shows the drawing. groups: (m,) from
    layer_groups, computed here when not given.
    """
    groups = layer_groups(textured.template) if groups is None else groups
    depth = np.round(layer_depth(textured.face_depth(pose), groups), _DEPTH_DECIMALS)
    front_sheet = (textured.template.face_layer == 0).astype(np.int64)
    return np.lexsort((front_sheet, -depth))


def downsample(image: np.ndarray, scale: int) -> np.ndarray:
    """(H*s, W*s[, C]) float32 -> (H, W[, C]) mean over each s x s block."""
    if scale == 1:
        return image
    h, w = image.shape[0] // scale, image.shape[1] // scale
    # INTER_AREA with an integer factor is exactly the block mean
    return cv2.resize(np.ascontiguousarray(image, dtype=np.float32), (w, h), interpolation=cv2.INTER_AREA)


_REMAP = dict(interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0, 0))
WINDOW_MARGIN_PX = 2  # a face fills the samples within half a sample of it: 1 px would do


@dataclass(frozen=True)
class Window:
    """The pixels [y0, y1) x [x0, x1) of a frame that a deformed mesh can cover: a frame is rendered there only
    (the character covers a fraction of it), and every pixel comes out as in a whole-frame rendering."""

    y0: int
    y1: int
    x0: int
    x1: int

    @classmethod
    def around(cls, X: np.ndarray, shape: tuple[int, int], margin: int = WINDOW_MARGIN_PX) -> Window:
        """The box of vertices X (n, 2) pixels, grown by margin and clipped to the (H, W) frame."""
        X = np.asarray(X, np.float64)
        h, w = shape
        if not len(X) or not np.isfinite(X).all():
            return cls(0, h, 0, w)
        lo, hi = np.floor(X.min(0)).astype(int) - margin, np.ceil(X.max(0)).astype(int) + margin + 1
        return cls(int(np.clip(lo[1], 0, h)), int(np.clip(hi[1], 0, h)), int(np.clip(lo[0], 0, w)),
                   int(np.clip(hi[0], 0, w)))

    @property
    def empty(self) -> bool:
        return self.y1 <= self.y0 or self.x1 <= self.x0

    @property
    def shape(self) -> tuple[int, int]:
        return self.y1 - self.y0, self.x1 - self.x0

    @property
    def origin(self) -> tuple[int, int]:
        return self.y0, self.x0

    @property
    def slices(self) -> tuple[slice, slice]:
        return slice(self.y0, self.y1), slice(self.x0, self.x1)


class Renderer:
    """One textured template ready to draw many frames: its premultiplied textures are made once."""

    def __init__(self, textured: TexturedTemplate):
        self.textured = textured
        self.front = premultiply(textured.texture)
        self.back = premultiply(textured.back_texture)
        offset = textured.back_offset()  # (m,) x of each face's back level in back_texture; None: all at level 0
        self.back_offset = offset if offset.any() else None
        self.groups = layer_groups(textured.template)
        tpl = textured.template
        self.sheet = tpl.face_layer == 0  # (m,) the front sheet's faces
        used = np.unique(tpl.faces[self.sheet])
        # a front sheet slit along a contact or cut around a region has vertices twice at one rest point;
        # only then can it lie over itself without folding
        self.slit = len(np.unique(np.round(tpl.rest[used], 6), axis=0)) < len(used)

    def _samples(self, X: np.ndarray, pose: np.ndarray, window: Window, s: int):
        """Premultiplied RGBA of every supersample of the window (h*s, w*s, 4), the back map, hidden-face mask and
        face ids behind it."""
        tpl = self.textured.template
        order = depth_order(self.textured, pose, self.groups)
        ids = rasterize_ids(X, tpl.faces, order, window.shape, s, window.origin)
        A = rest_maps(X, tpl.rest, tpl.faces)
        pre, map_x, map_y, hidden = self._sample_ids(ids, A, s, window.origin)
        if not self.slit:
            return pre, map_x, map_y, hidden, ids
        # the front sheet over itself (a slit limb across the body): a soft edge on top shows the sheet
        # beneath it, not the paper; pockets stay out, so at rest nothing shows through the drawing's edges.
        # The sheet painted front to back leaves the face beneath standing (the backmost, where three stack)
        sheet = self.sheet
        soft = (ids >= 0) & sheet.take(np.maximum(ids, 0)) & (pre[..., 3] < 0.999)
        if not soft.any():
            return pre, map_x, map_y, hidden, ids
        back_to_front = order[::-1]
        under = rasterize_ids(X, tpl.faces, back_to_front[sheet[back_to_front]], window.shape, s, window.origin)
        ys, xs = np.nonzero(soft & (under >= 0) & (under != ids) & sheet.take(np.maximum(under, 0)))
        if len(ys):
            f = under[ys, xs]
            Af = A[f]  # (k, 2, 3): the face beneath, read at the sample's pixel centre as back_map reads
            px = (window.origin[1] + xs // s).astype(np.float32)
            py = (window.origin[0] + ys // s).astype(np.float32)
            bx = Af[:, 0, 0] * px + Af[:, 0, 1] * py + Af[:, 0, 2]
            by = Af[:, 1, 0] * px + Af[:, 1, 1] * py + Af[:, 1, 2]
            # a neighbour sharing the sample on an edge (the fill is inclusive) reads the same drawing point
            apart = np.hypot(bx - map_x[ys, xs], by - map_y[ys, xs]) > 1.0
            ys, xs, f, bx, by = ys[apart], xs[apart], f[apart], bx[apart], by[apart]
            back = self.textured.face_source[f] > 0
            below = np.zeros((len(ys), 4), np.float32)
            bx_back = bx if self.back_offset is None else bx + self.back_offset[f]
            for texture, pick, x in ((self.front, ~back, bx), (self.back, back, bx_back)):
                if pick.any():  # a (1, k) map samples just these points
                    below[pick] = cv2.remap(texture, x[pick][None], by[pick][None], **_REMAP)[0]
            pre[ys, xs] += (1.0 - pre[ys, xs, 3:4]) * below
        return pre, map_x, map_y, hidden, ids

    def _sample_ids(self, ids: np.ndarray, A: np.ndarray, s: int, origin: tuple[int, int]):
        """Premultiplied RGBA, back map and hidden-face mask of face ids (h*s, w*s) of a window starting at pixel
        origin, under rest maps A (m, 2, 3)."""
        map_x, map_y = back_map(ids, A, s, origin)
        hidden = (ids >= 0) & (self.textured.face_source.take(np.maximum(ids, 0)) > 0)  # the back texture's faces
        # each texture is sampled only where it is selected (the other map points off-texture, giving 0),
        # so the two premultiplied results add up to the composite
        off = np.float32(-1e4)
        pre = cv2.remap(self.front, np.where(hidden, off, map_x), map_y, **_REMAP)
        pre += cv2.remap(self.back, np.where(hidden, self._back_x(map_x, ids), off), map_y, **_REMAP)
        return pre, map_x, map_y, hidden

    def _back_x(self, map_x: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """The back map's x (h*s, w*s) moved to each face's back level in back_texture (as is without levels)."""
        return map_x if self.back_offset is None else map_x + self.back_offset.take(np.maximum(ids, 0))

    def frame(self, X: np.ndarray, pose: np.ndarray, shape: tuple[int, int] | None = None,
              supersample: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """X (n, 2) deformed vertices, pixels; pose (J, 3) -> (rgba (H, W, 4) float32 straight, inpainted (H, W)
        bool, distorted (H, W) bool: visible pixels drawn by faces scaled beyond DISTORTION_LIMIT)."""
        shape = tuple(shape) if shape is not None else self.textured.texture.shape[:2]
        s = int(supersample)
        window = Window.around(X, shape)
        rgba = np.zeros((*shape, 4), np.float32)
        inpainted, distorted = np.zeros(shape, bool), np.zeros(shape, bool)
        if window.empty:
            return rgba, inpainted, distorted
        crop = window.slices
        pre, map_x, map_y, hidden, ids = self._samples(X, pose, window, s)
        rgba[crop], inpainted[crop], distorted[crop] = self._finish(X, pre, map_x, map_y, hidden, ids, s)
        return rgba, inpainted, distorted

    def _finish(self, X, pre, map_x, map_y, hidden, ids, s: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A window's samples -> its (rgba, inpainted, distorted) pixels, as frame() returns them."""
        rgba = unpremultiply(downsample(pre, s))
        bh, bw = self.textured.back_inpainted.shape
        cx = np.clip(np.rint(self._back_x(map_x, ids)).astype(np.int64), 0, bw - 1)
        cy = np.clip(np.rint(map_y).astype(np.int64), 0, bh - 1)
        # source-1 faces may hold inpainted pixels too (samples invisible in the other keyframe)
        filled = hidden & self.textured.back_inpainted[cy, cx]
        shown = rgba[..., 3] > 0.5
        inpainted = (downsample(filled.astype(np.float32), s) >= 0.5) & shown
        tpl = self.textured.template
        torn = np.append(face_stretch(tpl.rest, X, tpl.faces) > DISTORTION_LIMIT, False)  # id -1 -> False
        distorted = (downsample(torn[ids].astype(np.float32), s) >= 0.5) & shown
        return rgba.astype(np.float32), inpainted, distorted

    def over_white(self, X: np.ndarray, pose: np.ndarray, shape: tuple[int, int], supersample: int = 1) -> np.ndarray:
        """The same frame composited over white, (H, W, 3) float32: no round trip through straight alpha."""
        s = int(supersample)
        out = np.ones((*shape, 3), np.float32)
        window = Window.around(X, shape)
        if not window.empty:
            pre = downsample(self._samples(X, pose, window, s)[0], s)
            out[window.slices] = pre[..., :3] + (1.0 - pre[..., 3:4])
        return out


def render(textured: TexturedTemplate, X: np.ndarray, pose: np.ndarray,
           shape: tuple[int, int] | None = None, supersample: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """X: (n, 2) deformed vertices, pixels; pose (J, 3) -> (rgba (H, W, 4) float32 straight, inpainted (H, W) bool)."""
    rgba, inpainted, _ = Renderer(textured).frame(X, pose, shape, supersample)
    return rgba, inpainted
