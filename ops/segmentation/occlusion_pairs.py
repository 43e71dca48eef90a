"""One occlusion region per overlapping bone pair (§4.1), its front read off the drawing where it shows, z elsewhere.

Where the bodies A and B of two bones overlap, the region R = A ∩ B is bounded by pieces of both outlines:
∂A inside B and ∂B inside A. Only the front body's piece is drawn: if A is in front, its outline runs on across
B (a stroke, or A's colour against B's), while B's outline under A is hidden (A shows on both sides of it: no
stroke, no colour step). Which outline a boundary pixel of R lies on is read from the slimmer of the two
bodies, whose outline lies about its radius from its bone (a limb; the other may be a torso, a skirt or a
belly, shaped anyhow): a pixel on its rim is its outline, a pixel well inside it is the other's. The bone
whose outline shows a contrast where the other's shows none is in front. A flat silhouette, a soft wash or a
region whose two outlines read alike says nothing, and then the bones' depths (z) decide; where the drawing
and z disagree the drawing's reading stands, with one warning naming both bones.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage

from ops.segmentation.bones import bone_depths, bone_radii, thick_regions
from ops.segmentation.contacts import scale_of
from ops.segmentation.skeleton_guide import bone_distance_stack
from ops.types import Skeleton

REACH = 1.5  # a bone's body reaches this many body radii (+ REACH_PX) from its segment (occlusion_drawing's rule)
REACH_PX = 3.0
MIN_REGION_PX = 12  # smaller pair regions are noise (the ground truth's own minimum overlap)
MIN_REGION_SHARE = 0.02  # a piece of a pair smaller than this share of the mask joins the region it borders
NEIGHBOUR_SHARE = 0.1  # a neighbour of the front bone whose body covers this share of the region is in front too
CONTRAST_PX = 2  # an outline is read within this distance (grows with the drawing) of the region's boundary
SILHOUETTE_PX = 2  # boundary pixels this near the paper are the character's outline, drawn whoever is in front
RIM_TOL, RIM_TOL_PX = 0.35, 2.0  # a pixel this near (share of the radius, at least px) the slim body's rim is on it
# The drawing's reading overrides z, so it must be sure: these were chosen on the 3D generator's train split
# (samples 7 000 000 on, never trained on) for 95% right readings on true pair regions (docs/occlusion.md)
MIN_SIDE_PX = 30  # both outline pieces at least this long (pixels of a 256 px drawing; grows with it)
MIN_CONTRAST = 0.3  # a drawn outline's median contrast (0-1 colour units per pixel) is at least this
MIN_STEP = 0.1  # ... this much more than the hidden one's and the region's inside
MIN_RATIO = 2.0  # ... and twice the hidden one's


@dataclass
class FrontReading:
    """What the drawing says about one pair region: front bone (-1: it does not say), the median contrast
    along each bone's outline piece, and how many boundary pixels each piece has."""

    front: int
    contrast: dict[int, float]
    pixels: dict[int, int]


def bone_pairs(mask: np.ndarray, pose: np.ndarray, skeleton: Skeleton, radii: np.ndarray) -> np.ndarray:
    """(H, W, 2) int64 the two bones whose bodies overlap at each pixel of a (H, W) bool mask, as (lower, higher)
    index; -1 off the mask. The first is the body nearest the pixel (distance over its radius, among bodies that
    reach it: REACH radii + REACH_PX); the second the nearest other body, or, where the pixel lies within the
    radius of a body that shares no joint with the first, the nearest such (a forearm across the belly near its
    own elbow is over the belly; a knee beside the other knee is still a knee). Bones shorter than their radius
    come last.
    radii: (B,) body radii, pixels."""
    out = np.full(mask.shape + (2,), -1, np.int64)
    ys, xs = np.nonzero(mask)
    if len(xs) == 0 or len(skeleton.bones) < 2:
        return out
    ends = pose[:, :2].astype(np.float32)[skeleton.bones]
    dist = bone_distance_stack(np.stack([xs, ys], 1).astype(np.float32), ends)  # (B, N)
    reach = REACH * radii + REACH_PX
    ranked = np.where(dist <= reach[:, None], dist / np.maximum(radii[:, None], 1.0), dist + 1e6)
    # a bone shorter than its body is thick (a clavicle, a hip bone, AnimatedDrawings' root-hip) joins bodies and
    # is none: its radius is read off the body around it. It takes a pixel only where no longer bone reaches.
    length = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    ranked[length < radii] += 1e3
    first = np.argmin(ranked, axis=0)
    others = ranked.copy()
    others[first, np.arange(len(xs))] = np.inf
    second = np.argmin(others, axis=0)
    apart = np.where(skeleton.adjacent_bones()[first], np.inf, others.T).T  # bodies not joined to the first
    nearest_apart = np.argmin(apart, axis=0)
    cols = np.arange(len(xs))
    inside = dist[nearest_apart, cols] <= radii[nearest_apart]  # the pixel lies within that body's radius
    second = np.where(inside & np.isfinite(apart[nearest_apart, cols]), nearest_apart, second)
    out[ys, xs, 0], out[ys, xs, 1] = np.minimum(first, second), np.maximum(first, second)
    return out


def pair_components(mask: np.ndarray, pose: np.ndarray, skeleton: Skeleton, radii: np.ndarray
                    ) -> list[tuple[int, int, np.ndarray]]:
    """(bone a, bone b, (H, W) bool region) for every pair of bones that share pixels of a (H, W) bool mask.

    Each pixel's pair (bone_pairs) is smoothed by a majority over a window about the slimmest body's radius, so
    that where two pairs are equally near (thighs side by side under a belly) the region does not break into
    specks; a piece smaller than the larger of MIN_REGION_PX and MIN_REGION_SHARE of the mask joins the region
    it borders most (or is dropped when it borders none)."""
    pairs = bone_pairs(mask, pose, skeleton, radii)
    n_bones = len(skeleton.bones)
    key = np.where(mask, pairs[..., 0] * n_bones + pairs[..., 1], -1)
    keys = np.unique(key[key >= 0])
    if len(keys) > 1:
        size = 2 * int(np.clip(np.median(radii), 2, 8)) + 1
        votes = np.stack([ndimage.uniform_filter((key == k).astype(np.float32), size) for k in keys])
        key = np.where(mask, keys[np.argmax(votes, axis=0)], -1)
    labels = np.zeros(mask.shape, np.int64)
    owner: list[int] = []
    for k in np.unique(key[key >= 0]):
        pieces, n = ndimage.label(key == k, structure=np.ones((3, 3), bool))
        labels[pieces > 0] = pieces[pieces > 0] + len(owner)
        owner += [int(k)] * n
    sizes = np.bincount(labels.ravel(), minlength=len(owner) + 1)
    small = max(MIN_REGION_PX, MIN_REGION_SHARE * int(mask.sum()))
    for piece in np.argsort(sizes[1:], kind="stable") + 1:  # smallest first: a speck joins its neighbour
        if sizes[piece] >= small or sizes[piece] == 0:
            continue
        inside = labels == piece
        ring = labels[ndimage.binary_dilation(inside, np.ones((3, 3), bool)) & ~inside]
        ring = ring[(ring > 0) & (ring != piece)]
        labels[inside] = np.bincount(ring).argmax() if len(ring) else 0
        if len(ring):
            sizes[labels[inside][0]] += sizes[piece]
        sizes[piece] = 0
    out = []
    for k in sorted(set(owner)):
        region = np.isin(labels, [i + 1 for i, o in enumerate(owner) if o == k])
        if region.sum() >= MIN_REGION_PX:
            a, b = divmod(k, n_bones)
            out.append((a, b, region))
    return out


def contrast_map(drawing: np.ndarray) -> np.ndarray:
    """(H, W) float32 colour contrast of a (H, W, C) float32 (0-1) or uint8 drawing: the largest Sobel gradient
    magnitude over its colour channels, in colour units per pixel (a step from 0 to 1 reads about 1)."""
    img = drawing.astype(np.float32) / 255.0 if drawing.dtype == np.uint8 else np.asarray(drawing, np.float32)
    img = img[..., :3] if img.ndim == 3 else img[..., None]
    out = np.zeros(img.shape[:2], np.float32)
    for c in range(img.shape[2]):
        ch = np.ascontiguousarray(img[..., c])
        gx, gy = cv2.Sobel(ch, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(ch, cv2.CV_32F, 0, 1, ksize=3)
        np.maximum(out, np.hypot(gx, gy) / 4.0, out=out)
    return out


def outline_contrast(drawing: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """(H, W) float32 the contrast_map's largest value within the reach of a stroke (CONTRAST_PX times the
    character's scale, scale_of) of each pixel: what read_front reads along an outline."""
    reach = int(round(CONTRAST_PX * scale))
    return cv2.dilate(contrast_map(drawing), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1,) * 2))


def read_front(region: np.ndarray, a: int, b: int, contrast: np.ndarray, foreground: np.ndarray, pose: np.ndarray,
               skeleton: Skeleton, radii: np.ndarray) -> FrontReading:
    """Which of bones a and b the drawing puts in front in their (H, W) bool overlap region.

    contrast: outline_contrast of the drawing; foreground: (H, W) bool;
    radii: (B,) body radii, pixels."""
    reading = FrontReading(-1, {a: 0.0, b: 0.0}, {a: 0, b: 0})
    min_side = MIN_SIDE_PX * scale_of(foreground)
    four = ndimage.generate_binary_structure(2, 1)
    rim = region & ~ndimage.binary_erosion(region, four)
    rim &= ~ndimage.binary_dilation(~foreground, iterations=SILHOUETTE_PX)  # the character's outline: always drawn
    ys, xs = np.nonzero(rim)
    if len(xs) < 2 * min_side:
        return reading
    slim, other = (a, b) if radii[a] <= radii[b] else (b, a)
    ends = pose[:, :2].astype(np.float32)[skeleton.bones[[slim]]]
    d = bone_distance_stack(np.stack([xs, ys], 1).astype(np.float32), ends)[0]
    r = float(radii[slim])
    tol = max(RIM_TOL_PX, RIM_TOL * r)
    on_slim, in_slim = np.abs(d - r) <= tol, d < r - tol  # on the slim body's outline; deep inside it: the other's
    inside = ndimage.binary_erosion(region, iterations=2) if region.sum() > 40 else np.zeros_like(region)
    # the region's own contrast, away from its rim; none in a small or thin one (its median would be NaN, and a
    # NaN base reads no bone as drawn)
    base = float(np.median(contrast[inside])) if inside.any() else 0.0
    for bone, sel in ((slim, on_slim), (other, in_slim)):
        reading.pixels[bone] = int(sel.sum())
        reading.contrast[bone] = float(np.median(contrast[ys[sel], xs[sel]])) if sel.any() else base
    for front, back in ((a, b), (b, a)):
        cf, cb = reading.contrast[front], reading.contrast[back]
        drawn = reading.pixels[front] >= min_side and cf > max(base + MIN_STEP, MIN_CONTRAST)
        hidden = reading.pixels[back] >= min_side and cf - cb > MIN_STEP and cf > MIN_RATIO * cb
        if drawn and hidden:
            reading.front = front
            break
    return reading


def with_neighbours(front: int, back: int, region: np.ndarray, foreground: np.ndarray, pose: np.ndarray,
                    skeleton: Skeleton, cache: dict) -> np.ndarray:
    """(f,) int64 front bones of a pair region: the front bone and each of its neighbours (not the back bone nor
    one of its) whose body covers NEIGHBOUR_SHARE of the region, as the skeleton rule has them, so the upper arm's
    handles at the elbow stay on the front sheet with the forearm's. cache keeps the bodies between regions."""
    adjacent = skeleton.adjacent_bones()
    near = [int(n) for n in np.nonzero(adjacent[front] & ~adjacent[back])[0] if n != front]
    if not near:
        return np.array([front], np.int64)
    if "thick" not in cache:
        cache["thick"] = thick_regions(foreground, pose, skeleton)
    area = max(int(region.sum()), 1)
    joined = [n for n in near if (cache["thick"][n] & region).sum() >= NEIGHBOUR_SHARE * area]
    return np.array(sorted({front, *joined}), np.int64)


def contradiction(source: str, skeleton: Skeleton, seen: int, back: int, depth: np.ndarray) -> str:
    """The one warning line when the drawing puts bone `seen` in front of `back` and z says the opposite."""
    s, k = bone_name(skeleton, seen), bone_name(skeleton, back)
    return (f"{source}: bones {s} and {k} overlap; the drawing shows {s} in front but z says {k} (z {depth[back]:.2f} "
            f"< {depth[seen]:.2f}); the drawing's reading is used; fix: give {s}'s joints a smaller z than {k}'s, "
            "or paint an occlusion mask")


def check_fronts(regions: list[np.ndarray], fronts: list[np.ndarray], drawing: np.ndarray, foreground: np.ndarray,
                 pose: np.ndarray, skeleton: Skeleton, source: str = "drawing") -> tuple[list[np.ndarray], list[str]]:
    """The (b,) int64 front bones of other predictors' (H, W) bool regions (the skeleton rule's, the hybrid's), each
    checked against the drawing: where the region's main bone pair (its largest pair component) shows the other
    bone's outline running through it, that bone and its neighbours there are the front, with the warning that
    names both. drawing: (H, W, C) float32 (0-1) or uint8; foreground: (H, W) bool; pose: (J, 3)."""
    if not regions:
        return list(fronts), []
    radii = bone_radii(foreground, pose, skeleton)
    depth = bone_depths(pose, skeleton)
    contrast = outline_contrast(drawing, scale_of(foreground))
    out, warnings, cache = [], [], {}
    for region, front in zip(regions, fronts):
        parts = pair_components(region, pose, skeleton, radii)
        if not parts:
            out.append(front)
            continue
        a, b, piece = max(parts, key=lambda p: int(p[2].sum()))
        seen = read_front(piece, a, b, contrast, foreground, pose, skeleton, radii).front
        back = b if seen == a else a
        if seen >= 0 and seen not in front and back in front:
            warnings.append(contradiction(source, skeleton, seen, back, depth))
            out.append(with_neighbours(seen, back, region, foreground, pose, skeleton, cache))
        else:
            out.append(front)
    return out, warnings


def bone_name(skeleton: Skeleton, b: int) -> str:
    """'parent-child' joint names of bone b."""
    p, c = skeleton.bones[b]
    return f"{skeleton.joints[p]}-{skeleton.joints[c]}"


def pair_regions(mask: np.ndarray, drawing: np.ndarray | None, foreground: np.ndarray, pose: np.ndarray,
                 skeleton: Skeleton, radii: np.ndarray, source: str = "drawing"
                 ) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    """One region per overlapping bone pair of a (H, W) bool occlusion mask, back to front, its (f,) int64 front
    bones (the pair's front bone and its neighbours there, with_neighbours), and warnings. drawing: (H, W, C) float32 (0-1) or uint8 (None: z alone decides); foreground: (H, W)
    bool; pose: (J, 3) pixels and depth (larger = farther); radii: (B,) body radii, pixels; source names the
    keyframe in warnings."""
    depth = bone_depths(pose, skeleton)
    contrast = None if drawing is None else outline_contrast(drawing, scale_of(foreground))
    regions, fronts, keys, warnings = [], [], [], []
    cache: dict = {}
    for a, b, region in pair_components(mask, pose, skeleton, radii):
        by_z = a if depth[a] < depth[b] else b if depth[b] < depth[a] else -1
        seen = read_front(region, a, b, contrast, foreground, pose, skeleton, radii).front if contrast is not None \
            else -1
        front = seen if seen >= 0 else by_z if by_z >= 0 else a
        if seen >= 0 and by_z >= 0 and seen != by_z:
            warnings.append(contradiction(source, skeleton, seen, b if seen == a else a, depth))
        elif seen < 0 and by_z < 0 and not skeleton.adjacent_bones()[a, b]:  # a joint's order does not matter
            warnings.append(f"{source}: bones {bone_name(skeleton, a)} and {bone_name(skeleton, b)} overlap with "
                            "equal depths and the drawing does not show which is in front; "
                            f"{bone_name(skeleton, a)} is taken; fix: give their joints different z")
        regions.append(region)
        fronts.append(with_neighbours(front, b if front == a else a, region, foreground, pose, skeleton, cache))
        keys.append(-depth[front])  # larger z (farther) first: back to front
    order = np.argsort(np.array(keys), kind="stable")
    return [regions[i] for i in order], [fronts[i] for i in order], warnings
