"""A bitmap drawing posed as a paper puppet: per-bone parts, linear blend skinning near joints, parts in depth order.

The "world" that realdev_shots.py films, as AnimatedDrawings animates a child's drawing: every foreground pixel
belongs to one bone's part (the bone whose capsule it lies deepest in), each part turns rigidly with its bone,
and near a joint the weights of the parts that meet there blend smoothly (linear blend skinning), so an elbow
bends without tearing. Each foreground pixel is a quad of two triangles whose corners move by the skinned map;
triangles are rasterized with a depth buffer ordered by their part's depth, so a limb in front covers the body.
Where the drawing moved away the paper shows (a smooth estimate of the paper's colour). It shares nothing with
the method's own deformation or rendering (ops/geometry, ops/appearance): numpy, SciPy and OpenCV only.

Conventions: images (H, W[, 3]) float32 RGB in [0, 1]; pixel (row y, column x) has its centre at (x, y);
joints (J, 2) float64 x, y pixels; a part is the bone parent(j) -> j, named by its distal joint j.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage

LEAF_REACH = 1.5  # a leaf bone (head, hand, foot) reaches on past its joint to the mask's edge, at most this x its length
BIN_SIZES = (2, 4, 8, 16, 64)  # candidate-pixel windows of the rasterizer, px


@dataclass(frozen=True)
class Rig:
    """A drawing cut into parts and skinned to its skeleton, ready to pose."""

    texture: np.ndarray  # (H, W, 3) float32 the drawing
    background: np.ndarray  # (H, W, 3) float32 the drawing with the character replaced by paper
    mask: np.ndarray  # (H, W) bool pixels that move (the character)
    rest: np.ndarray  # (J, 2) float64 joints as drawn, px
    parents: np.ndarray  # (J,) int64, -1 at the root
    bones: np.ndarray  # (B,) int64 distal joint of the bone each part moves with
    labels: np.ndarray  # (H, W) int16 part of each mask pixel, -1 elsewhere
    corner_weights: np.ndarray  # (B, H + 1, W + 1) float32 skinning weights at pixel corners, sum 1 on the mask
    adjacent: np.ndarray  # (B, B) bool: the two parts' bones share a joint (or are the same part)


def segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) float64 distance of points (N, 2) to the segment a-b (2,)."""
    ab = b - a
    t = np.clip(((points - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def _leaf_end(mask: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The end of a leaf bone a-b carried on along its direction while inside the mask (the head past the neck
    joint, the hand past the wrist), at most LEAF_REACH x its length."""
    d = b - a
    n = float(np.linalg.norm(d))
    h, w = mask.shape
    end = b.copy()
    for s in np.arange(1.0, LEAF_REACH * n, 1.0):
        p = b + d / n * s
        x, y = int(round(p[0])), int(round(p[1]))
        if not (0 <= x < w and 0 <= y < h and mask[y, x]):
            break
        end = p
    return end


def part_labels(mask: np.ndarray, rest: np.ndarray, parents: np.ndarray, bones: np.ndarray, group: np.ndarray,
                reach: float = 1.3) -> np.ndarray:
    """(H, W) int16 part per mask pixel (-1 elsewhere).

    Each bone's capsule holds the pixels within reach x its half-thickness of it (the median distance to the
    mask's edge along the bone's outer part, away from the joint that may sit inside the body; a leaf bone runs on
    to the mask's edge: the head, a hand); where capsules meet, the pixel goes to the one it lies deepest in
    relative to that thickness, so a wide belly stays with the spine although an arm's bone passes nearer to its
    side. Bones of one group (bones that move as one) make one part; a part keeps its largest piece; pixels
    outside every capsule (a mitten's thumb, a pigtail) join the part of the nearest pixel inside one.
    group: (B,) part index of each bone, 0 .. P - 1.
    """
    depth = ndimage.distance_transform_edt(mask)
    ys, xs = np.nonzero(mask)
    pts = np.stack([xs, ys], 1).astype(np.float64)
    h, w = mask.shape
    has_child = np.zeros(len(parents), bool)
    has_child[parents[parents >= 0]] = True
    rel = np.empty((len(bones), len(pts)))
    for k, j in enumerate(bones):
        a, b = rest[parents[j]], rest[j]
        if not has_child[j]:
            b = _leaf_end(mask, a, b)
        along = a + np.linspace(0.4, 0.9, 16)[:, None] * (b - a)
        ix = np.clip(np.round(along).astype(int), 0, [w - 1, h - 1])
        radius = max(float(np.median(depth[ix[:, 1], ix[:, 0]])), 1.0)
        rel[k] = segment_distance(pts, a, b) / radius
    near = np.argmin(rel, axis=0)
    grid = np.full(mask.shape, -1, np.int64)
    grid[ys, xs] = np.where(rel[near, np.arange(len(pts))] <= reach, group[near], -1)
    for k in range(int(group.max()) + 1):
        pieces, n = ndimage.label(grid == k)
        if n > 1:  # a capsule reaching over a gap into another limb keeps its own piece
            sizes = np.bincount(pieces.ravel())
            sizes[0] = 0
            grid[(pieces > 0) & (pieces != np.argmax(sizes))] = -1
    if (grid >= 0).any():
        _, (iy, ix) = ndimage.distance_transform_edt(grid < 0, return_indices=True)
        grid = grid[iy, ix]
    else:
        grid[ys, xs] = group[near]
    return np.where(mask, grid, -1).astype(np.int16)


def skinning_weights(labels: np.ndarray, n_parts: int, blend_px: float) -> np.ndarray:
    """(B, H, W) float32 weights: each part's indicator diffused inside the mask (never across paper), so they
    blend over about blend_px either side of a boundary between parts and are exactly one-hot farther away."""
    mask = (labels >= 0).astype(np.float32)
    iterations = int(np.ceil(blend_px ** 2 / 2.0))  # a 5 x 5 box has variance 2 px^2
    norm = np.maximum(cv2.blur(mask, (5, 5), borderType=cv2.BORDER_CONSTANT), 1e-12)
    weights = np.stack([(labels == k).astype(np.float32) for k in range(n_parts)])
    for _ in range(iterations):
        for k in range(n_parts):
            weights[k] = cv2.blur(weights[k], (5, 5), borderType=cv2.BORDER_CONSTANT) / norm * mask
    weights /= np.maximum(weights.sum(0, keepdims=True), 1e-12)
    weights[weights < 1e-6] = 0.0  # a far part's diffused trace would tug a rigid part by float noise
    weights /= np.maximum(weights.sum(0, keepdims=True), 1e-12)
    return weights * mask


def _corners(weights: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(B, H + 1, W + 1): at each pixel corner the mean weights of the mask pixels around it."""
    pad_w = np.pad(weights, ((0, 0), (1, 1), (1, 1)))
    pad_m = np.pad(mask.astype(np.float32), 1)
    total = pad_w[:, :-1, :-1] + pad_w[:, 1:, :-1] + pad_w[:, :-1, 1:] + pad_w[:, 1:, 1:]
    count = pad_m[:-1, :-1] + pad_m[1:, :-1] + pad_m[:-1, 1:] + pad_m[1:, 1:]
    return (total / np.maximum(count, 1.0)).astype(np.float32)


def skeleton_bones(rest: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """(B,) int64 distal joint of every bone of nonzero length (AnimatedDrawings' root -> hip has none)."""
    return np.array([j for j in range(len(parents)) if parents[j] >= 0
                     and np.linalg.norm(rest[j] - rest[parents[j]]) > 1e-6], np.int64)


def rigid_maps(rest: np.ndarray, parents: np.ndarray, bones: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(B, 2, 3) float64 rigid map of every bone from the rest drawing to the pose (J, 2+) px: turned about its
    proximal joint by the bone's change of direction and carried to where that joint went."""
    pose = np.asarray(pose, np.float64)[:, :2]
    out = np.zeros((len(bones), 2, 3))
    for k, j in enumerate(bones):
        p = parents[j]
        d0, d1 = rest[j] - rest[p], pose[j] - pose[p]
        theta = np.arctan2(d1[1], d1[0]) - np.arctan2(d0[1], d0[0])
        c, s = np.cos(theta), np.sin(theta)
        rot = np.array([[c, -s], [s, c]])
        out[k, :, :2] = rot
        out[k, :, 2] = pose[p] - rot @ rest[p]
    return out


def moving_together(rest: np.ndarray, parents: np.ndarray, motion: np.ndarray, tol_px: float = 0.25) -> np.ndarray:
    """(B,) part index of every bone of skeleton_bones: bones whose rigid maps agree (within tol_px at their
    joints) in every pose of motion (F, J, 2+) share a part, as collarbones ride the spine; so no seam crosses
    the body between two pieces that never move apart."""
    rest = np.asarray(rest, np.float64)[:, :2]
    bones = skeleton_bones(rest, parents)
    maps = np.stack([rigid_maps(rest, parents, bones, pose) for pose in motion])  # (F, B, 2, 3)
    group = np.arange(len(bones))
    for a in range(len(bones)):
        for b in range(a):
            if group[b] != b:
                continue
            pts = rest[[parents[bones[a]], bones[a], parents[bones[b]], bones[b]]]
            ma = np.einsum("fij,nj->fni", maps[:, a, :, :2], pts) + maps[:, a, None, :, 2]
            mb = np.einsum("fij,nj->fni", maps[:, b, :, :2], pts) + maps[:, b, None, :, 2]
            if np.abs(ma - mb).max() <= tol_px:
                group[a] = b
                break
    return np.unique(group, return_inverse=True)[1]


def build_rig(texture: np.ndarray, background: np.ndarray, mask: np.ndarray, rest: np.ndarray,
              parents: np.ndarray, blend_px: float, group: np.ndarray | None = None) -> Rig:
    """Cut the drawing into parts and skin them; blend_px: half-width of the blend at a joint, px; group: (B,)
    part of each bone of skeleton_bones (moving_together), None: a part per bone."""
    parents = np.asarray(parents, np.int64)
    rest = np.asarray(rest, np.float64)[:, :2]
    bones = skeleton_bones(rest, parents)
    group = np.arange(len(bones)) if group is None else np.asarray(group, np.int64)
    n_parts = int(group.max()) + 1
    labels = part_labels(mask, rest, parents, bones, group)
    weights = skinning_weights(labels, n_parts, blend_px)
    first = np.array([np.nonzero(group == k)[0][0] for k in range(n_parts)])  # each part moves as its first bone
    ends = [{int(v) for b in np.nonzero(group == k)[0] for v in (parents[bones[b]], bones[b])} for k in range(n_parts)]
    adjacent = np.array([[bool(a & b) for b in ends] for a in ends])
    return Rig(texture.astype(np.float32), background.astype(np.float32), labels >= 0, rest, parents, bones[first],
               labels, _corners(weights, labels >= 0), adjacent)


def bone_transforms(rig: Rig, pose: np.ndarray) -> np.ndarray:
    """(B, 2, 3) float64 rigid map of every part from the rest drawing to the pose (J, 2+) px."""
    return rigid_maps(rig.rest, rig.parents, rig.bones, pose)


def _bilinear(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, C) image sampled at (N,) x, y px, clamped to the image."""
    h, w = image.shape[:2]
    x = np.clip(x, 0, w - 1)
    y = np.clip(y, 0, h - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), w - 2)
    y0 = np.minimum(np.floor(y).astype(np.int64), h - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    return ((image[y0, x0] * (1 - fx) + image[y0, x0 + 1] * fx) * (1 - fy)
            + (image[y0 + 1, x0] * (1 - fx) + image[y0 + 1, x0 + 1] * fx) * fy)


@dataclass(frozen=True)
class Posed:
    """One rendered frame."""

    image: np.ndarray  # (H, W, 3) float32
    front: np.ndarray  # (H, W) int16 part seen at each pixel, -1 where paper shows
    crossing: np.ndarray  # (H, W) bool: the part seen covers a part its bone does not touch (a limb over the body)
    covered: np.ndarray  # (H, W) int16 where crossing: the nearest such part behind it; -1 elsewhere


def _triangles(rig: Rig, maps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per triangle of the mask's pixel quads: source corners (T, 3, 2), posed corners (T, 3, 2), part (T,)."""
    ys, xs = np.nonzero(rig.mask)
    corner = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    src = np.stack([xs, ys], 1)[:, None, :] + corner[None]  # (N, 4, 2)
    cy = (ys[:, None] + np.array([0, 0, 1, 1])[None]).ravel()
    cx = (xs[:, None] + np.array([0, 1, 1, 0])[None]).ravel()
    w = rig.corner_weights[:, cy, cx].T.reshape(len(xs), 4, -1).astype(np.float64)  # (N, 4, B)
    w /= w.sum(-1, keepdims=True)  # to float64's precision: at rest every corner stays where it is
    blended = np.einsum("nvk,kab->nvab", w, maps)  # (N, 4, 2, 3): linear blend skinning, one map per corner
    dst = np.einsum("nvab,nvb->nva", blended[..., :2], src) + blended[..., 2]
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    part = rig.labels[ys, xs].astype(np.int64)
    return (src[:, tri].reshape(-1, 3, 2), dst[:, tri].reshape(-1, 3, 2), np.repeat(part, 2))


def _rasterize(dst: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel centres inside each triangle: (M,) triangle index, (M,) flat pixel index, (M, 3) barycentrics."""
    h, w = shape
    lo = np.ceil(dst.min(1) - 1e-9).astype(np.int64)
    hi = np.floor(dst.max(1) + 1e-9).astype(np.int64)
    span = (hi - lo).max(1) + 1
    out_t, out_p, out_b = [], [], []
    previous = 0
    for size in BIN_SIZES:
        sel = np.nonzero((span > previous) & (span <= size))[0]
        previous = size
        if sel.size == 0:
            continue
        gx, gy = np.meshgrid(np.arange(size), np.arange(size))
        px = lo[sel, 0, None] + gx.ravel()[None]
        py = lo[sel, 1, None] + gy.ravel()[None]
        a, b, c = dst[sel, 0], dst[sel, 1], dst[sel, 2]
        det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
        ok_tri = np.abs(det) > 1e-12
        det = np.where(ok_tri, det, 1.0)[:, None]
        l1 = ((px - a[:, 0, None]) * (c[:, 1, None] - a[:, 1, None])
              - (c[:, 0, None] - a[:, 0, None]) * (py - a[:, 1, None])) / det
        l2 = ((b[:, 0, None] - a[:, 0, None]) * (py - a[:, 1, None])
              - (px - a[:, 0, None]) * (b[:, 1, None] - a[:, 1, None])) / det
        l0 = 1.0 - l1 - l2
        inside = ((l0 >= -1e-9) & (l1 >= -1e-9) & (l2 >= -1e-9) & ok_tri[:, None]
                  & (px <= hi[sel, 0, None]) & (py <= hi[sel, 1, None]) & (px >= 0) & (px < w) & (py >= 0) & (py < h))
        ti, ci = np.nonzero(inside)
        out_t.append(sel[ti])
        out_p.append(py[ti, ci] * w + px[ti, ci])
        out_b.append(np.stack([l0[ti, ci], l1[ti, ci], l2[ti, ci]], 1))
    if not out_t:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3))
    return np.concatenate(out_t), np.concatenate(out_p), np.concatenate(out_b)


def render(rig: Rig, pose: np.ndarray) -> Posed:
    """The drawing posed (J, 3) (x, y px, z larger = farther): every pixel shows the nearest part over it, the
    background where none does. Ties in depth go to the part of the later joint (limbs over the body). Where a
    limb folds over itself at a joint (the part in front and parts its bone touches, before any other part), the
    darkest of them shows in each channel, so a bent elbow's paper does not cut its own line."""
    pose = np.asarray(pose, np.float64)
    h, w = rig.mask.shape
    src, dst, part = _triangles(rig, bone_transforms(rig, pose))
    tri, pix, bary = _rasterize(dst, (h, w))
    hit_part = part[tri]
    z = pose[rig.bones, 2] - 1e-6 * np.arange(len(rig.bones))  # (B,) depth of each part, ties to the later bone
    order = np.lexsort((z[hit_part], pix))
    tri, pix, bary, hit_part = tri[order], pix[order], bary[order], hit_part[order]
    first = np.ones(len(pix), bool)
    first[1:] = pix[1:] != pix[:-1]
    front = np.full(h * w, -1, np.int16)
    front[pix[first]] = hit_part[first]
    behind = ~rig.adjacent[front[pix], hit_part]  # a part the front one's bone does not touch: a limb over a part
    start = np.maximum.accumulate(np.where(first, np.arange(len(pix)), 0))
    seen = np.cumsum(behind)
    fold = (seen - seen[start] + behind[start]) == 0  # hits before the first such part in their pixel
    at = np.einsum("mv,mva->ma", bary[fold], src[tri[fold]])
    at = np.round(at * 1e6) / 1e6  # at rest a pixel centre maps onto itself up to rounding: sample it exactly
    colour = np.full((h * w, 3), np.inf, np.float32)
    np.minimum.at(colour, pix[fold], _bilinear(rig.texture, at[:, 0], at[:, 1]).astype(np.float32))
    image = rig.background.reshape(-1, 3).copy()
    image[pix[first]] = colour[pix[first]]
    under, first_under = np.unique(pix[behind], return_index=True)  # hits are sorted near to far in each pixel
    covered = np.full(h * w, -1, np.int16)
    covered[under] = hit_part[behind][first_under]
    return Posed(image.reshape(h, w, 3), front.reshape(h, w), covered.reshape(h, w) >= 0, covered.reshape(h, w))


def paper_field(image: np.ndarray, valid: np.ndarray, sigma_px: float) -> np.ndarray:
    """(H, W, 3) float32 smooth estimate of the paper's colour: the valid pixels' colours averaged with a Gaussian
    of sigma_px (normalized convolution, on a grid 8x coarser), the median paper colour where none is near."""
    h, w = valid.shape
    f = 8
    small = cv2.resize(image * valid[..., None], (max(1, w // f), max(1, h // f)), interpolation=cv2.INTER_AREA)
    weight = cv2.resize(valid.astype(np.float32), (max(1, w // f), max(1, h // f)), interpolation=cv2.INTER_AREA)
    s = max(sigma_px / f, 1.0)
    num = cv2.GaussianBlur(small, (0, 0), s, borderType=cv2.BORDER_CONSTANT)
    den = cv2.GaussianBlur(weight, (0, 0), s, borderType=cv2.BORDER_CONSTANT)
    median = np.median(image[valid], axis=0) if valid.any() else np.ones(3, np.float32)
    trust = np.clip(den / 0.2, 0.0, 1.0)[..., None]
    field = trust * num / np.maximum(den, 1e-6)[..., None] + (1 - trust) * median
    return cv2.resize(field.astype(np.float32), (w, h), interpolation=cv2.INTER_LINEAR)
