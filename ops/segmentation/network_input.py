"""The occlusion network's view of a keyframe (§4.1): crop, working scale, paper-relative colour, skeleton channels.

Training (tools/train_occlusion.py) and inference (ops.segmentation.occlusion_drawing) both go through
these functions, so the network always sees a character at the same size: the joints' bounding box is
scaled to WORK_EXTENT_PX on its longer side, whatever the keyframe's resolution.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ops.segmentation.occlusion_infer import STRIDE
from ops.segmentation.skeleton_guide import guide_channels
from ops.types import Skeleton

WORK_EXTENT_PX = 128.0  # longer side of the joints' bounding box at the working scale
MAX_ZOOM = 4.0  # a tiny skeleton is not blown up beyond this (nor shrunk below 1 / this)
CROP_MARGIN_PX = 8  # around the character's bounding box, at the keyframe's scale


@dataclass
class WorkFrame:
    """Where the network's input lies in the keyframe: the crop box (x0, y0, x1, y1), pixels, and the zoom."""

    box: tuple[int, int, int, int]
    zoom: float  # working pixels per keyframe pixel

    def work_shape(self) -> tuple[int, int]:
        """(h, w) of the crop at the working scale, before padding to a multiple of STRIDE."""
        x0, y0, x1, y1 = self.box
        return max(1, int(round((y1 - y0) * self.zoom))), max(1, int(round((x1 - x0) * self.zoom)))


def working_zoom(pose: np.ndarray) -> float:
    """Working pixels per keyframe pixel for a (J, 3) pose: the joints' box to WORK_EXTENT_PX."""
    xy = pose[:, :2]
    extent = float(np.max(xy.max(0) - xy.min(0))) if len(xy) else 0.0
    return float(np.clip(WORK_EXTENT_PX / max(extent, 1.0), 1.0 / MAX_ZOOM, MAX_ZOOM))


def work_frame(foreground: np.ndarray, pose: np.ndarray) -> WorkFrame:
    """The crop around the (H, W) bool foreground and the joints, with the working zoom."""
    h, w = foreground.shape
    ys, xs = np.nonzero(foreground)
    xy = pose[:, :2]
    lo = np.minimum([xs.min(), ys.min()], xy.min(0)) if len(xs) else xy.min(0)
    hi = np.maximum([xs.max(), ys.max()], xy.max(0)) if len(xs) else xy.max(0)
    x0, y0 = (int(np.floor(v)) - CROP_MARGIN_PX for v in lo)
    x1, y1 = (int(np.ceil(v)) + 1 + CROP_MARGIN_PX for v in hi)
    return WorkFrame((max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)), working_zoom(pose))


def paper_colour(image: np.ndarray) -> np.ndarray:
    """(3,) float32 paper colour of a (H, W, 3) uint8 drawing: the median of its brightest 30% of pixels.

    Needs no foreground, so the network's input does not depend on the foreground segmentation.
    """
    flat = image.reshape(-1, 3).astype(np.float32)
    lum = flat @ np.array([0.299, 0.587, 0.114], np.float32)
    bright = flat[lum >= np.percentile(lum, 70)]
    return np.median(bright, axis=0).astype(np.float32)


def resample(img: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """A (H, W[, C]) array resized to (h, w): area averaging when shrinking, bilinear when enlarging."""
    h, w = shape
    shrink = h * w < img.shape[0] * img.shape[1]
    return cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR)


def colour_channels(image: np.ndarray, paper: np.ndarray) -> np.ndarray:
    """(3, H, W) float32 drawing minus paper colour, in [-1, 1], of a (H, W, 3) uint8 (or float 0-255) image."""
    return np.clip((image.astype(np.float32) - paper) / 255.0 * 2.0, -1.0, 1.0).transpose(2, 0, 1)


def network_input(image: np.ndarray, foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton
                  ) -> tuple[np.ndarray, WorkFrame]:
    """(IN_CHANNELS, h, w) float32 network input of a (H, W, 3) uint8 drawing, padded to multiples of STRIDE.

    foreground: (H, W) bool, only for the crop; pose: (J, 3) pixels and depth.
    """
    frame = work_frame(foreground, pose)
    x0, y0, x1, y1 = frame.box
    hw = frame.work_shape()
    paper = paper_colour(image)
    crop = resample(np.ascontiguousarray(image[y0:y1, x0:x1]), hw)
    ph, pw = (-(-s // STRIDE) * STRIDE for s in hw)
    colour = np.zeros((3, ph, pw), np.float32)  # padding reads as paper
    colour[:, : hw[0], : hw[1]] = colour_channels(crop, paper)
    return np.concatenate([colour, guide_channels(to_work(pose, frame), skeleton, (ph, pw))]), frame


def to_work(pose: np.ndarray, frame: WorkFrame) -> np.ndarray:
    """(J, 3) pose in working pixels (z unchanged) of a (J, 3) keyframe pose."""
    out = np.array(pose, np.float64, copy=True)
    x0, y0, x1, y1 = frame.box
    h, w = frame.work_shape()
    # the resize's own per-axis factors (rounded sizes); pixel i covers [i - 0.5, i + 0.5] as cv2.resize has it
    out[:, 0] = (out[:, 0] - x0 + 0.5) * (w / (x1 - x0)) - 0.5
    out[:, 1] = (out[:, 1] - y0 + 0.5) * (h / (y1 - y0)) - 0.5
    return out


def from_work(prob: np.ndarray, frame: WorkFrame, shape: tuple[int, int]) -> np.ndarray:
    """(H, W) float32 keyframe map of a (h', w') working-scale map (padding ignored), zero outside the crop."""
    x0, y0, x1, y1 = frame.box
    hw = frame.work_shape()
    out = np.zeros(shape, np.float32)
    out[y0:y1, x0:x1] = resample(np.ascontiguousarray(prob[: hw[0], : hw[1]], np.float32), (y1 - y0, x1 - x0))
    return out
