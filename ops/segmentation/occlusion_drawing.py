"""Occlusion masks read from the drawing with the skeleton as a guide (§4.1, issue 15).

A small U-Net (ops.segmentation.occlusion_net; run in NumPy by ops.segmentation.occlusion_infer), trained on
generated characters (posed 3D bodies drawn with a depth buffer, and the 2D generator's flat parts), marks every
pixel where one part covers another: an arm across the body, a round thigh inside a round belly, a skirt over
the thighs, crossing shins, a near leg over a far one in a side view, joint overlaps. It sees the drawing's
strokes and colour edges and, through the skeleton channels, which bones are near and which of them is nearer
the viewer. Its mask (inside the foreground) splits into one region per overlapping bone pair, whose front is
read off the drawing where it shows and taken from z where it does not (ops.segmentation.occlusion_pairs).

The skeleton rule (ops.segmentation.occlusion) stays the fallback where the drawing gives no evidence:
a region it predicts on a patch of the drawing that shows no stroke or colour edge at all (a flat
silhouette, a manual-mask-like fill) is kept when the network did not mark it.

The default predictor ("hybrid", shape_by_drawing) goes the other way: the skeleton rule's regions, each cut
to the network's marks or to the front bones' bodies between the drawing's strokes, whichever keeps more.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from ops.segmentation.bones import bone_depths, bone_radii, thick_regions
from ops.segmentation.contacts import drawn_bodies, stroke_reach
from ops.segmentation.network_input import from_work, network_input, resample, to_work
from ops.segmentation.occlusion import predict_occlusion as skeleton_occlusion
from ops.segmentation.occlusion_infer import occlusion_logits
from ops.segmentation.occlusion_pairs import bone_pairs, pair_regions
from ops.segmentation.skeleton_guide import bone_distance_stack
from ops.types import Skeleton

THRESHOLD = 0.5  # network probability above which a pixel is occluded
REACH = 1.5  # a bone's body reaches this many body radii (+ REACH_PX) from its segment
REACH_PX = 3.0
EDGE_LEVEL = 0.08  # colour step (0-1 scale) that counts as a stroke or colour edge: evidence in the drawing
MAX_FLAT_EDGE_SHARE = 0.01  # a region whose pixels are edges less often than this shows nothing
MIN_MARKED_SHARE = 0.2  # a skeleton rule's region the network marks this much of is shaped by the marks
NEAR_MARK_PX = 2  # ... keeping its pixels this near a mark
MIN_HELD_SHARE = 0.3  # a skeleton rule's region its front bones' drawn bodies hold this much of may be cut to them


def to_uint8(drawing: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB of a (H, W, C) float32 [0, 1] drawing (alpha composited over white)."""
    img = drawing if drawing.ndim == 3 else drawing[..., None]
    rgb = img[..., :3] if img.shape[2] >= 3 else np.repeat(img[..., :1], 3, axis=2)
    if img.shape[2] in (2, 4):
        a = img[..., -1:]
        rgb = rgb * a + (1.0 - a)
    return np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)


def front_and_back(points: np.ndarray, pose: np.ndarray, skeleton: Skeleton, radii: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(N,) int64 front and back bone at each of (N, 2) pixel positions (x, y); radii: (B,) body radii, pixels.

    Of the bones whose bodies reach the pixel (REACH body radii), the two nearest; the one with the smaller
    depth is in front (equal depths: the nearer bone). A pixel no body reaches uses the two nearest bones.
    """
    bones = skeleton.bones
    ends = pose[:, :2].astype(np.float32)[bones]
    dist = bone_distance_stack(points.astype(np.float32), ends)  # (B, N)
    if len(bones) == 1:
        zero = np.zeros(len(points), np.int64)
        return zero, zero
    reach = REACH * radii + REACH_PX
    ranked = np.where(dist <= reach[:, None], dist, dist + 1e6)  # bodies that reach the pixel come first
    two = np.argsort(ranked, axis=0, kind="stable")[:2]
    depth = bone_depths(pose, skeleton)
    d0, d1 = depth[two[0]], depth[two[1]]
    first_front = (d0 < d1) | (np.isclose(d0, d1))  # two[0] is the nearer one
    front = np.where(first_front, two[0], two[1])
    back = np.where(first_front, two[1], two[0])
    return front.astype(np.int64), back.astype(np.int64)


def joined_pixels(mask: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
                  radii: np.ndarray) -> np.ndarray:
    """(H, W) bool pixels of a (H, W) bool mask where the two bones meeting there are joined, read as the skeleton
    rule reads them (ops.segmentation.occlusion): they share a joint (the round ends at an elbow, a hip), or a
    neighbouring bone whose body holds the pixel (spine - clavicle - upper arm; a thick tail's short segments,
    each over the next but one). That is a joint the mesh bends at, not an occlusion; a pocket there opened as
    a dark blob when the limb moved, and a curled tail's joints made one pocket of the whole tail.
    The two bones are the pair regions' (occlusion_pairs.bone_pairs): the nearest body and the nearest body not
    joined to it, so a forearm lying across the belly near its own elbow is the forearm over the belly, not the
    forearm at the elbow. radii: (B,) body radii, pixels."""
    ys, xs = np.nonzero(mask)
    out = np.zeros(mask.shape, bool)
    if len(xs) == 0 or len(skeleton.bones) < 2:
        return out
    pairs = bone_pairs(mask, pose, skeleton, radii)
    front, back = pairs[ys, xs, 0], pairs[ys, xs, 1]
    adjacent = skeleton.adjacent_bones()
    joined = adjacent[front, back]
    between = adjacent[front] & adjacent[back]  # (N, B) bones next to both
    between[np.arange(len(xs)), front] = False  # a bone is its own neighbour
    between[np.arange(len(xs)), back] = False
    if between.any():
        thick = thick_regions(foreground, pose, skeleton)
        joined |= (between & thick[:, ys, xs].T).any(axis=1)
    out[ys[joined], xs[joined]] = True
    return out


def edge_map(colour: np.ndarray) -> np.ndarray:
    """(h, w) bool strokes and colour edges of (3, h, w) float32 paper-relative colour (network_input's first
    channels, 2 units = full scale): a colour step above EDGE_LEVEL."""
    f = colour / 2.0
    gx = np.abs(ndimage.sobel(f, axis=2)).max(axis=0) / 4.0
    gy = np.abs(ndimage.sobel(f, axis=1)).max(axis=0) / 4.0
    return np.maximum(gx, gy) > EDGE_LEVEL


def flat_fallback(colour: np.ndarray, marked: np.ndarray, foreground: np.ndarray, pose: np.ndarray,
                  skeleton: Skeleton) -> tuple[np.ndarray, int, list[str]]:
    """The skeleton rule where the drawing gives no evidence, at one scale (the network's working scale).

    colour: (3, h, w) paper-relative colour; marked: (h, w) bool what the network marked; foreground: (h, w)
    bool; pose: (J, 3) in these pixels. Returns the (h, w) bool union of the skeleton rule's regions that lie
    on patches showing no stroke or colour edge and that the network marked less than half of, their count,
    warnings.
    """
    regions, _, warnings = skeleton_occlusion(foreground, pose, skeleton)
    out = np.zeros(foreground.shape, bool)
    if not regions:
        return out, 0, warnings
    inner = ndimage.binary_erosion(foreground, iterations=2)  # the silhouette's own outline is no evidence
    edges = edge_map(colour) & inner
    kept = 0
    for r in regions:
        patch = ndimage.binary_dilation(r, iterations=2) & inner
        flat = edges[patch].mean() < MAX_FLAT_EDGE_SHARE if patch.any() else True
        if flat and (marked & r).sum() < 0.5 * r.sum():  # the network saw little of it: weak evidence
            out |= r
            kept += 1
    if kept:
        warnings.append(f"{kept} occlusion region(s) from the skeleton rule where the drawing shows no "
                        "stroke or colour edge")
    return out, kept, warnings


def occlusion_marks(drawing: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
                    fallback: bool = True) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(H, W) bool pixels of a (H, W, C) float32 or uint8 drawing where one part covers another (the network's
    mask, with the skeleton rule's regions where the drawing shows nothing unless `fallback` is False), (B,)
    body radii in keyframe pixels, and warnings. foreground: (H, W) bool; pose: (J, 3).

    The network and the fallback work at the network's working scale (the character about WORK_EXTENT_PX
    across); only the mask is brought back to the keyframe's resolution.
    """
    image = drawing if drawing.dtype == np.uint8 and drawing.ndim == 3 else to_uint8(drawing)
    fg = np.asarray(foreground, bool)
    x, frame = network_input(image, fg, pose, skeleton)
    prob = 1.0 / (1.0 + np.exp(-occlusion_logits(x)))
    h, w = frame.work_shape()
    x0, y0, x1, y1 = frame.box
    wfg = resample(fg[y0:y1, x0:x1].astype(np.float32), (h, w)) > 0.5
    wpose = to_work(pose, frame)
    marked = (prob[:h, :w] > THRESHOLD) & wfg
    warnings: list[str] = []
    if fallback:
        extra, _, warnings = flat_fallback(x[:3, :h, :w], marked, wfg, wpose, skeleton)
        marked = marked | extra
    mask = (from_work(marked.astype(np.float32), frame, fg.shape) > 0.5) & fg
    radii = bone_radii(wfg, wpose, skeleton) / frame.zoom  # a body's radius in keyframe pixels
    return mask, radii, warnings


def predict_occlusion(drawing: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
                      joint_overlaps: bool = True, source: str = "drawing"
                      ) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    """Occlusion regions ((H, W) bool each, back to front) of a (H, W, C) float32 or uint8 drawing, their (1,)
    int64 front bone, and warnings. foreground: (H, W) bool; pose: (J, 3) pixels and depth (larger = farther);
    source names the keyframe in warnings.

    The mask is occlusion_marks'; joint_overlaps False leaves out the pixels where two joined bones meet
    (joined_pixels). It is split into one region per overlapping bone pair, the front read off the drawing
    where it shows and from z where it does not (ops.segmentation.occlusion_pairs).
    """
    fg = np.asarray(foreground, bool)
    if not fg.any() or len(skeleton.bones) == 0:
        return [], [], []
    mask, radii, warnings = occlusion_marks(drawing, fg, pose, skeleton)
    if not joint_overlaps:
        mask &= ~joined_pixels(mask, fg, pose, skeleton, radii)
    regions, fronts, w = pair_regions(mask, drawing, fg, pose, skeleton, radii, source)
    return regions, fronts, warnings + w


def split_by_pairs(regions: list[np.ndarray], drawing: np.ndarray, foreground: np.ndarray, pose: np.ndarray,
                   skeleton: Skeleton, source: str = "drawing") -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    """Other predictors' (H, W) bool regions as one region per overlapping bone pair, back to front, with their (f,)
    int64 front bones and warnings, as the network's are split (occlusion_pairs.pair_regions; the pixels where two
    joined bones meet left out). The skeleton rule joins every overlap that touches another into one region: an
    arm over the torso and the near thigh over the far one in a side view become one region whose outline and cut
    serve neither. drawing: (H, W, C) float32 (0-1) or uint8; foreground: (H, W) bool; pose: (J, 3)."""
    fg = np.asarray(foreground, bool)
    mask = np.any(regions, axis=0) & fg if regions else np.zeros_like(fg)
    if not mask.any():
        return [], [], []
    radii = bone_radii(fg, pose, skeleton)
    mask &= ~joined_pixels(mask, fg, pose, skeleton, radii)
    return pair_regions(mask, drawing, fg, pose, skeleton, radii, source)


def shape_by_drawing(regions: list[np.ndarray], fronts: list[np.ndarray], drawing: np.ndarray,
                     foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton, parts: tuple | None = None
                     ) -> list[np.ndarray]:
    """The skeleton rule's (H, W) bool regions, with their (b,) int64 front bones, shaped by the (H, W, C) float32
    (0-1) or uint8 drawing. foreground: (H, W) bool; pose: (J, 3); parts: contacts.drawn_parts' result for this
    drawing and foreground, when the caller has it already.

    The rule's region is where two bodies, drawn as capsules around their bones, overlap: a forearm's capsule
    across a watercolour shirt is wider than the painted forearm, and the band of shirt it takes moves with the
    arm. The drawing says where the forearm's edge runs, in two readings:
    - marked: the network's marks (within NEAR_MARK_PX);
    - held: the front bones' bodies between the drawing's strokes (contacts.drawn_bodies), with the strokes
      that outline them.
    Each reading only cuts; a region is cut by the reading that keeps more of it, when that one keeps at least
    its share (MIN_MARKED_SHARE, MIN_HELD_SHARE), and otherwise stays whole. The network finds painted limbs
    whose strokes break (two_poses' arm, legs_cross); the strokes find an inked forearm across a scanned belly
    where the network marks only half of it and the rest of the capsule drags the belly along (scan_jpeg). A
    reading that keeps less has missed part of the front body, so the one that keeps more is trusted.
    Where the rule finds no occlusion nothing is taken (a thick tail's segments, a skirt's hem over the
    thighs); where neither reading sees a region (a flat silhouette) the rule stands. Front bones, order and
    warnings stay the rule's; the marks need no fallback to the rule here (it would run the rule a second
    time, to keep what is kept anyway).
    """
    fg = np.asarray(foreground, bool)
    if not regions or not fg.any():
        return list(regions)
    marked = occlusion_marks(drawing, fg, pose, skeleton, fallback=False)[0]
    near = ndimage.binary_dilation(marked, structure=np.ones((3, 3), bool), iterations=NEAR_MARK_PX)
    colour = drawing.astype(np.float32) / 255.0 if drawing.dtype == np.uint8 else drawing  # strokes read 0-1
    owner = drawn_bodies(colour, fg, pose, skeleton, parts)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * stroke_reach(fg) + 1,) * 2)
    shaped = []
    for region, front in zip(regions, fronts):
        held = cv2.dilate(np.isin(owner, front).astype(np.uint8), disc) > 0
        size = max(int(region.sum()), 1)
        readings = [(float((region & near).sum()) / size, MIN_MARKED_SHARE, near),
                    (float((region & held).sum()) / size, MIN_HELD_SHARE, held)]
        kept = [(share, cut) for share, least, cut in readings if share >= least]
        shaped.append(region & max(kept, key=lambda k: k[0])[1] if kept else region)
    return shaped
