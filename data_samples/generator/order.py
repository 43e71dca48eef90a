"""Painting order of the parts: back to front by depth."""
from __future__ import annotations

import numpy as np

from .model import Character


def draw_order(char: Character, pose: np.ndarray) -> list[int]:
    """Bone indices sorted back to front: mean joint depth descending, ties by bone index; undrawn bones skipped."""
    depth = [0.5 * (pose[p, 2] + pose[c, 2]) for p, c in char.bones]
    order = sorted(range(len(depth)), key=lambda i: (-depth[i], i))
    return [i for i in order if char.parts[char.bones[i][1]].shape != "none"]
