"""The paper a shot is drawn on, as a background plate: what every method's frames are judged over.

Our frames are the character alone (alpha = coverage, docs/shot-format.md); the
ground truth and the frame-interpolation baselines are whole pictures, paper
included. On white paper, compositing over white is fair to all. On tinted,
unevenly lit or grainy paper it is not: every frame of ours would differ from
the truth over all the paper. The plate is the paper as the keyframes show
it: each keyframe's own pixels where it shows bare paper (the first keyframe's where
several do), and the smooth paper model (Masks.paper)
under both characters. Composited over it, frame 0 of ours is keyframe 0.
"""
from __future__ import annotations

import numpy as np

from ops.shotio.image_io import to_rgba


def paper_plate(keys: list[np.ndarray], coverages: list[np.ndarray], papers: list[np.ndarray]) -> np.ndarray:
    """(H, W, 3) float32 plate from the keyframes (H, W, C), their coverage (H, W) and paper models (H, W, 3):
    the first keyframe's own pixels that show bare paper there, and the mean paper model under every character."""
    model = sum((np.asarray(p, np.float32) for p in papers[1:]), np.asarray(papers[0], np.float32)) / len(papers)
    plate = model
    for key, cov in reversed(list(zip(keys, coverages))):  # the first key that shows bare paper wins
        plate = np.where((np.asarray(cov) <= 0)[..., None], to_rgba(key)[..., :3], plate)
    return plate.astype(np.float32)


def over(frames: np.ndarray, plate: np.ndarray) -> np.ndarray:
    """(T, H, W, C) frames (RGBA straight alpha, or opaque RGB) composited over the (H, W, 3) plate -> (T, H, W, 3)."""
    frames = np.asarray(frames, np.float32)
    if frames.shape[-1] != 4:
        return frames[..., :3]
    a = frames[..., 3:]
    return frames[..., :3] * a + (1.0 - a) * plate
