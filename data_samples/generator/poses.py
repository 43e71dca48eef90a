"""Key poses from bone angles, in-between poses by the shot loader's rule, and the rounding written to JSON."""
from __future__ import annotations

import math

import numpy as np

from ops.shotio.interpolate import interpolate_pose as _loader_interpolate


def forward(parents: list[int], root: tuple[float, float], world_deg: dict[int, float],
            length: dict[int, float], z: dict[int, float]) -> np.ndarray:
    """(J, 3) joints from world bone angles (deg, y down: 90 = straight down) and lengths (px)."""
    out = np.zeros((len(parents), 3))
    out[0, :2] = root
    for c in range(1, len(parents)):  # parents precede children in every character here
        a = math.radians(world_deg[c])
        out[c, :2] = out[parents[c], :2] + length[c] * np.array([math.cos(a), math.sin(a)])
    out[:, 2] = [z.get(j, 0.0) for j in range(len(parents))]
    return out


def interpolate_pose(a: np.ndarray, b: np.ndarray, s: float, parents: list[int]) -> np.ndarray:
    """(J, 3) pose at fraction s, by the shot loader's own rule, so ground truth matches what it computes."""
    return _loader_interpolate(a, b, s, np.asarray(parents, dtype=np.int64))


def quantize(pose: np.ndarray) -> np.ndarray:
    """Round x, y to 0.01 px and z to 0.001 so the JSON values are exactly what gets drawn."""
    return np.concatenate([np.round(pose[:, :2], 2), np.round(pose[:, 2:], 3)], 1)
