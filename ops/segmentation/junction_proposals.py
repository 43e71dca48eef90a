"""T-junction proposals for keyframes that arrive without clicks (§4.1), found by a small network in the drawing.

Where one part covers another, the covered part's outline stops against the covering part's outline. A small
fully convolutional network (ops.segmentation.junction_infer, run in NumPy; trained on the generators' exact
junctions by tools/train_junctions.py) reads the drawing minus its paper and the skeleton channels (which bones
are near, which of them is nearer the viewer, which share a joint: joints meet in T's too, and do not count)
and gives per pixel a heat (is a junction here) and the covered outline's direction there. Its peaks (local
maxima of the heat, refined to a fraction of a pixel) are the proposals, scored by the heat, none within
MERGE_PX of a better one. A click always wins: proposals are for keyframes without clicks, and each carries
the stem's direction so the editor can draw it as a proposal to accept or reject.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ops.segmentation.contacts import scale_of
from ops.segmentation.junction_infer import junction_frame, junction_input, junction_outputs, to_keyframe
from ops.segmentation.network_input import WorkFrame
from ops.types import Masks, RefinedMasks, Skeleton

MERGE_PX = 3.0  # proposals closer than this (at the reference size, scale_of) are one
# the middle of the thresholds at which the 2D and 3D tuning sets together reach recall 0.8 and precision 0.6
# (tools/train_junctions.py's last line: 0.175 to 0.225 for the shipped weights); a person accepts or rejects
# each proposal, so the lower side of the range, where recall is, suits the editor
MIN_SCORE = 0.2


@dataclass
class JunctionProposals:
    """Candidate T-junctions of one keyframe, best first."""

    points: np.ndarray  # (k, 2) float64 x, y pixels
    scores: np.ndarray  # (k,) float64 in [0, 1]
    stems: np.ndarray  # (k, 2) float64 unit: the covered outline's direction, pointing away from the junction
    regions: np.ndarray  # (k,) int64 index of the nearest occlusion region (-1 when there is none)


def drawing_of(masks: Masks | RefinedMasks) -> np.ndarray:
    """(H, W, 3) uint8 RGB drawing the masks were read from: coverage x colour + (1 - coverage) x paper."""
    a = np.asarray(masks.coverage, np.float32)[..., None]
    rgb = a * np.asarray(masks.colour, np.float32)[..., :3] + (1.0 - a) * np.asarray(masks.paper, np.float32)[..., :3]
    return np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)


def heat_peaks(heat: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) x, y peaks of a (h, w) heatmap in [0, 1] and (k,) their heat, best first: pixels at least
    `threshold` that are the maximum of their 3 x 3 neighbourhood (plateaus give one), each moved to the
    heat-weighted centroid of its 3 x 3 neighbourhood (a fraction of a pixel)."""
    heat = np.asarray(heat, np.float32)
    peak = (heat >= threshold) & (heat >= ndimage.maximum_filter(heat, size=3, mode="constant"))
    ys, xs = np.nonzero(peak)
    if not len(ys):
        return np.zeros((0, 2)), np.zeros(0)
    scores = heat[ys, xs].astype(np.float64)
    order = np.argsort(-scores, kind="stable")
    ys, xs, scores = ys[order], xs[order], scores[order]
    taken = np.zeros(heat.shape, bool)
    pad = np.pad(heat, 1)
    keep, pts = [], []
    for i, (y, x) in enumerate(zip(ys, xs)):
        if taken[max(y - 1, 0):y + 2, max(x - 1, 0):x + 2].any():
            continue  # a plateau's second pixel
        taken[y, x] = True
        win = pad[y:y + 3, x:x + 3].astype(np.float64)
        off = np.array([-1.0, 0.0, 1.0])
        total = max(float(win.sum()), 1e-12)
        pts.append((x + float((win.sum(0) * off).sum()) / total, y + float((win.sum(1) * off).sum()) / total))
        keep.append(i)
    return np.asarray(pts, np.float64).reshape(-1, 2), scores[keep]


def _merge(points: np.ndarray, scores: np.ndarray, radius: float) -> np.ndarray:
    """(k,) int64 indices of the points (n, 2) kept, best score first, none within `radius` of a better one."""
    keep: list[int] = []
    for i in np.argsort(-scores, kind="stable"):
        if all(np.linalg.norm(points[i] - points[j]) >= radius for j in keep):
            keep.append(int(i))
    return np.asarray(keep, np.int64)


def _at(field: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(k,) values of a (H, W) field at the pixels nearest points (k, 2) x, y (clipped to the image)."""
    ij = np.clip(np.round(points[:, ::-1]).astype(np.int64), 0, np.array(field.shape[:2]) - 1)
    return field[ij[:, 0], ij[:, 1]]


def junction_maps(image: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
                  weights: tuple[str, str] | None = None) -> tuple[np.ndarray, np.ndarray, WorkFrame]:
    """The network's reading of a (H, W, 3) uint8 drawing with its (H, W) bool foreground (for the crop) at its
    (J, 3) pose: (h, w) float32 heat in [0, 1] and (2, h, w) float32 stem direction at the working scale, and
    the WorkFrame that maps working pixels to the keyframe's. The drawing and its mirror image are read and
    averaged (fewer lone false peaks). weights: (path, sha256) of another weights file (training's tuning)."""
    frame = junction_frame(np.asarray(foreground, bool), pose)
    x = junction_input(image, frame, pose, skeleton)
    h, w = frame.work_shape()
    heat = np.zeros((h, w), np.float32)
    stem = np.zeros((2, h, w), np.float32)
    for flip in (False, True):
        out = junction_outputs(np.ascontiguousarray(x[:, :, ::-1]) if flip else x, *(weights or ()))
        if flip:  # back to the drawing's side; the stem's x turns
            out = out[:, :, ::-1] * np.array([1.0, -1.0, 1.0], np.float32)[:, None, None]
        heat += 0.5 / (1.0 + np.exp(-out[0, :h, :w]))
        stem += 0.5 * np.tanh(out[1:3, :h, :w])
    return heat, stem, frame


def propose_t_junctions(masks: Masks | RefinedMasks, pose: np.ndarray, skeleton: Skeleton,
                        min_score: float = MIN_SCORE) -> JunctionProposals:
    """T-junction proposals of one keyframe from its masks (coverage, colour unmixed from the paper, occlusion
    regions) at its (J, 3) pose: the peaks of the network's heat (junction_maps, heat_peaks) scoring at least
    min_score, none within MERGE_PX of a better one, best first, each with the covered outline's direction and
    the nearest occlusion region."""
    empty = JunctionProposals(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros(0, np.int64))
    if not np.asarray(masks.foreground).any() or not len(skeleton.bones):
        return empty
    heat, stem_map, frame = junction_maps(drawing_of(masks), masks.foreground, pose, skeleton)
    work, scores = heat_peaks(heat, min_score)
    if not len(work):
        return empty
    ij = np.clip(np.round(work[:, ::-1]).astype(np.int64), 0, np.array(heat.shape) - 1)
    stems = stem_map[:, ij[:, 0], ij[:, 1]].T.astype(np.float64)
    stems /= np.maximum(np.linalg.norm(stems, axis=1, keepdims=True), 1e-9)
    points = to_keyframe(work, frame)
    keep = _merge(points, scores, MERGE_PX * scale_of(masks.foreground))
    points, scores, stems = points[keep], scores[keep], stems[keep]
    region = np.full(len(keep), -1, np.int64)
    if masks.occlusion and len(keep):
        d = np.stack([_at(ndimage.distance_transform_edt(~np.asarray(m, bool)), points) for m in masks.occlusion])
        region = np.argmin(d, axis=0).astype(np.int64)
    return JunctionProposals(points, scores, stems, region)
