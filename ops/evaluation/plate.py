"""The paper a shot is drawn on, as a background plate: what every method's frames are judged over.

Our frames are the character alone (alpha = coverage, SHOT_FORMAT.md); the
ground truth and the frame-interpolation baselines are whole pictures, paper
included. On white paper, compositing over white is fair to all. On tinted,
unevenly lit or grainy paper it is not: every frame of ours would differ from
the truth over all the paper. The plate is the paper as the keyframes show
it: each keyframe's own pixels where it shows bare paper, the other
keyframe's where only that one does, and the smooth paper model (Masks.paper)
under both characters. Composited over it, frame 0 of ours is keyframe 0.
"""
from __future__ import annotations

import numpy as np

from ops.shotio.image_io import to_rgba


def paper_plate(key0: np.ndarray, key1: np.ndarray, coverage0: np.ndarray, coverage1: np.ndarray,
                paper0: np.ndarray, paper1: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32 plate from the keyframes (H, W, C), their coverage (H, W) and paper models (H, W, 3)."""
    bare0 = (np.asarray(coverage0) <= 0)[..., None]
    bare1 = (np.asarray(coverage1) <= 0)[..., None]
    rgb0, rgb1 = to_rgba(key0)[..., :3], to_rgba(key1)[..., :3]
    model = 0.5 * (np.asarray(paper0, np.float32) + np.asarray(paper1, np.float32))
    return np.where(bare0, rgb0, np.where(bare1, rgb1, model)).astype(np.float32)


def over(frames: np.ndarray, plate: np.ndarray) -> np.ndarray:
    """(T, H, W, C) frames (RGBA straight alpha, or opaque RGB) composited over the (H, W, 3) plate -> (T, H, W, 3)."""
    frames = np.asarray(frames, np.float32)
    if frames.shape[-1] != 4:
        return frames[..., :3]
    a = frames[..., 3:]
    return frames[..., :3] * a + (1.0 - a) * plate
