"""The skeleton as image channels for the occlusion network (§4.1): nearest bones, their depth order, joints.

A pixel is occluded when it lies inside two parts' shapes; the network reads the shapes' outlines off the
drawing and needs the skeleton to know which bones are near a pixel and which of them is nearer the viewer.
Every channel is independent of the number of bones, so one network serves any skeleton.

Channels (C = GUIDE_CHANNELS), at a pixel with bones sorted by distance d1 <= d2 <= d3 (pixels):
  0-2  exp(-d_k / DIST_SCALE_PX) for the three nearest bone segments;
  3-4  tanh((z_k - z_1) / z_scale) for k = 2, 3: positive when the k-th nearest bone is farther than the
       nearest (z = mean joint depth of a bone, z_scale = a tenth of the skeleton's depth range);
  5-6  1 where the k-th nearest bone shares a joint with the nearest (a joint, not a crossing);
  7    exp(-dj / JOINT_SCALE_PX), dj the distance to the nearest joint.
"""
from __future__ import annotations

import numpy as np

from ops.segmentation.bones import bone_depths
from ops.types import Skeleton

GUIDE_CHANNELS = 8
DIST_SCALE_PX = 10.0  # at the network's working scale (ops.segmentation.occlusion_drawing.WORK_EXTENT_PX)
JOINT_SCALE_PX = 6.0
NEAREST = 3


def bone_distance_stack(xy: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """(B, N) float32 distance, pixels, from (N, 2) points to each of (B, 2, 2) bone segments."""
    a = ends[:, 0][:, None, :]  # (B, 1, 2)
    d = (ends[:, 1] - ends[:, 0])[:, None, :]
    L2 = np.maximum((d ** 2).sum(-1), 1e-12)  # (B, 1): a zero-length bone (root = hip) is a point
    rel = xy[None] - a
    t = np.clip((rel * d).sum(-1) / L2, 0.0, 1.0)
    return np.linalg.norm(rel - t[..., None] * d, axis=-1).astype(np.float32)


def guide_channels(pose: np.ndarray, skeleton: Skeleton, shape: tuple[int, int]) -> np.ndarray:
    """(GUIDE_CHANNELS, H, W) float32 skeleton channels of a (J, 3) pose (x, y pixels; z depth) on an (H, W) grid."""
    h, w = shape
    ys, xs = np.mgrid[0:h, 0:w]
    xy = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float32)
    bones = skeleton.bones
    out = np.zeros((GUIDE_CHANNELS, h * w), np.float32)
    if len(bones) == 0:
        return out.reshape(GUIDE_CHANNELS, h, w)
    ends = pose[:, :2].astype(np.float32)[bones]
    dist = bone_distance_stack(xy, ends)  # (B, N)
    k = min(NEAREST, len(bones))
    near = np.argsort(dist, axis=0, kind="stable")[:k] if len(bones) <= 8 else _k_smallest(dist, k)
    dnear = np.take_along_axis(dist, near, axis=0)
    depth = bone_depths(pose, skeleton).astype(np.float32)
    span = float(np.ptp(depth))
    z_scale = 0.1 * span if span > 1e-9 else 1.0
    adjacent = skeleton.adjacent_bones()
    for i in range(k):
        out[i] = np.exp(-dnear[i] / DIST_SCALE_PX)
    for i in range(1, k):
        out[2 + i] = np.tanh((depth[near[i]] - depth[near[0]]) / z_scale) if span > 1e-9 else 0.0
        out[4 + i] = adjacent[near[0], near[i]]
    joints = pose[:, :2].astype(np.float32)
    dj = np.sqrt(((xy[None] - joints[:, None]) ** 2).sum(-1)).min(axis=0)
    out[7] = np.exp(-dj / JOINT_SCALE_PX)
    return out.reshape(GUIDE_CHANNELS, h, w)


def _k_smallest(dist: np.ndarray, k: int) -> np.ndarray:
    """(k, N) int64 indices of the k smallest entries of each column of (B, N) dist, sorted by distance."""
    part = np.argpartition(dist, k - 1, axis=0)[:k]
    order = np.argsort(np.take_along_axis(dist, part, axis=0), axis=0, kind="stable")
    return np.take_along_axis(part, order, axis=0)
