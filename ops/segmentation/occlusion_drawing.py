"""Occlusion masks read from the drawing with the skeleton as a guide (§4.1, issue 15).

A small U-Net (ops.segmentation.occlusion_net), trained on generated characters, marks every pixel where
one part covers another: an arm across the body, a round thigh inside a round belly, a skirt over the
thighs, crossing shins, joint overlaps. It sees the drawing's strokes and colour edges and, through the
skeleton channels, which bones are near and which of them is nearer the viewer. Its mask (inside the
foreground) splits into connected regions; each region's front bones come from the skeleton: at every
pixel, of the two nearest bones whose bodies reach it, the one with the smaller depth is in front.

The skeleton rule (ops.segmentation.occlusion) stays the fallback where the drawing gives no evidence:
a region it predicts on a patch of the drawing that shows no stroke or colour edge at all (a flat
silhouette, a manual-mask-like fill) is kept when the network did not mark it.
"""
from __future__ import annotations

import numpy as np
import torch
from scipy import ndimage

from ops.segmentation.bones import bone_depths, bone_radii
from ops.segmentation.network_input import from_work, network_input
from ops.segmentation.occlusion import predict_occlusion as skeleton_occlusion
from ops.segmentation.occlusion_net import load_network
from ops.segmentation.skeleton_guide import bone_distance_stack
from ops.types import Skeleton

THRESHOLD = 0.5  # network probability above which a pixel is occluded
MIN_REGION_PX = 12  # the ground truth's own minimum overlap: smaller components are noise
REACH = 1.5  # a bone's body reaches this many body radii (+ REACH_PX) from its segment
REACH_PX = 3.0
MIN_FRONT_SHARE = 0.15  # a bone in front on this share of a region is one of its front bones
EDGE_LEVEL = 0.08  # colour step (0-1 scale) that counts as a stroke or colour edge: evidence in the drawing
MAX_FLAT_EDGE_SHARE = 0.01  # a region whose pixels are edges less often than this shows nothing


def to_uint8(drawing: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB of a (H, W, C) float32 [0, 1] drawing (alpha composited over white)."""
    img = drawing if drawing.ndim == 3 else drawing[..., None]
    rgb = img[..., :3] if img.shape[2] >= 3 else np.repeat(img[..., :1], 3, axis=2)
    if img.shape[2] in (2, 4):
        a = img[..., -1:]
        rgb = rgb * a + (1.0 - a)
    return np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)


def occlusion_probability(image: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
                          ) -> np.ndarray:
    """(H, W) float32 probability that a pixel shows a part covering another, of a (H, W, 3) uint8 drawing."""
    x, frame = network_input(image, foreground, pose, skeleton)
    net = load_network()
    with torch.inference_mode():
        prob = torch.sigmoid(net(torch.from_numpy(x)[None]))[0, 0].numpy()
    return from_work(prob, frame, foreground.shape)


def front_and_back(points: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(N,) int64 front and back bone at each of (N, 2) pixel positions (x, y).

    Of the bones whose bodies reach the pixel (REACH body radii), the two nearest; the one with the smaller
    depth is in front (equal depths: the nearer bone). A pixel no body reaches uses the two nearest bones.
    """
    bones = skeleton.bones
    ends = pose[:, :2].astype(np.float32)[bones]
    dist = bone_distance_stack(points.astype(np.float32), ends)  # (B, N)
    if len(bones) == 1:
        zero = np.zeros(len(points), np.int64)
        return zero, zero
    reach = REACH * bone_radii(foreground, pose, skeleton) + REACH_PX
    ranked = np.where(dist <= reach[:, None], dist, dist + 1e6)  # bodies that reach the pixel come first
    two = np.argsort(ranked, axis=0, kind="stable")[:2]
    depth = bone_depths(pose, skeleton)
    d0, d1 = depth[two[0]], depth[two[1]]
    first_front = (d0 < d1) | (np.isclose(d0, d1))  # two[0] is the nearer one
    front = np.where(first_front, two[0], two[1])
    back = np.where(first_front, two[1], two[0])
    return front.astype(np.int64), back.astype(np.int64)


def region_front_bones(region: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
                       ) -> tuple[int, np.ndarray]:
    """Main front bone and (b,) int64 front bones of a (H, W) bool region.

    Front bones: those in front on at least MIN_FRONT_SHARE of its pixels, less any bone that lies behind
    on more of them than in front (a region where the forearm covers the torso has the forearm only).
    """
    ys, xs = np.nonzero(region)
    front, back = front_and_back(np.stack([xs, ys], axis=1), foreground, pose, skeleton)
    nb = len(skeleton.bones)
    fc, bc = np.bincount(front, minlength=nb), np.bincount(back, minlength=nb)
    main = int(np.argmax(fc))
    keep = [b for b in np.nonzero(fc >= MIN_FRONT_SHARE * len(xs))[0] if b == main or fc[b] > bc[b]]
    return main, np.array(sorted(int(b) for b in keep), np.int64)


def edge_map(image: np.ndarray) -> np.ndarray:
    """(H, W) bool strokes and colour edges of a (H, W, 3) uint8 drawing: a colour step above EDGE_LEVEL."""
    f = image.astype(np.float32) / 255.0
    gx = np.abs(ndimage.sobel(f, axis=1)).max(axis=2) / 4.0
    gy = np.abs(ndimage.sobel(f, axis=0)).max(axis=2) / 4.0
    return np.maximum(gx, gy) > EDGE_LEVEL


def flat_fallback(image: np.ndarray, mask: np.ndarray, foreground: np.ndarray, pose: np.ndarray,
                  skeleton: Skeleton) -> tuple[list[np.ndarray], list[str]]:
    """Skeleton-rule regions on patches that show no edge (the drawing gives no evidence) and the network
    left unmarked: (H, W) bool each, and warnings."""
    regions, _, warnings = skeleton_occlusion(foreground, pose, skeleton)
    if not regions:
        return [], warnings
    inner = ndimage.binary_erosion(foreground, iterations=2)  # the silhouette's own outline is no evidence
    edges = edge_map(image) & inner
    kept = []
    for r in regions:
        patch = ndimage.binary_dilation(r, iterations=3) & inner
        flat = edges[patch].mean() < MAX_FLAT_EDGE_SHARE if patch.any() else True
        if flat and (mask & r).sum() < 0.1 * r.sum():
            kept.append(r)
    if kept:
        warnings.append(f"{len(kept)} occlusion region(s) from the skeleton rule where the drawing shows no "
                        "stroke or colour edge")
    return kept, warnings


def predict_occlusion(drawing: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
                      ) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    """Occlusion regions ((H, W) bool each, back to front) of a (H, W, C) float32 or uint8 drawing, their (b,)
    int64 front bones, and warnings. foreground: (H, W) bool; pose: (J, 3) pixels and depth (larger = farther)."""
    image = drawing if drawing.dtype == np.uint8 and drawing.ndim == 3 else to_uint8(drawing)
    fg = np.asarray(foreground, bool)
    if not fg.any() or len(skeleton.bones) == 0:
        return [], [], []
    mask = (occlusion_probability(image, fg, pose, skeleton) > THRESHOLD) & fg
    extra, warnings = flat_fallback(image, mask, fg, pose, skeleton)
    for r in extra:
        mask |= r
    labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    regions, fronts, keys = [], [], []
    depth = bone_depths(pose, skeleton)
    for lab in range(1, n + 1):
        if sizes[lab] < MIN_REGION_PX:
            continue
        region = labels == lab
        main, front = region_front_bones(region, fg, pose, skeleton)
        regions.append(region)
        fronts.append(front)
        keys.append(-depth[main])  # larger z (farther) first: back to front
    order = np.argsort(np.array(keys), kind="stable")
    return [regions[i] for i in order], [fronts[i] for i in order], warnings
