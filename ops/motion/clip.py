"""A 2D motion on a shot's skeleton, frame by frame: what a BVH retarget or a video track hands to the fit."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Clip:
    """Per output frame: the root's path, the world direction of the bones a source drives, depths.

    Bones the clip does not drive ride on their parent bone (ops.motion.fit); lengths come from the key poses,
    times `scales` where a source measures them (a tracked chain that grows as it nears the camera).
    """

    root: np.ndarray  # (F, 2) float64 root position, pixels; only its changes matter (the fit anchors it)
    angles: dict[int, np.ndarray]  # joint j -> (F,) float64 world angle of bone parent(j) -> j, radians,
    #                                image axes (x right, y down: +pi/2 points down), unwrapped over frames
    scales: dict[int, np.ndarray] = field(default_factory=dict)  # joint j -> (F,) float64 length factor
    depth: np.ndarray | None = None  # (F, J) float64 z per joint, larger = farther; None: keep the key poses'
    warnings: list[str] = field(default_factory=list)

    @property
    def frames(self) -> int:
        """Number of frames F."""
        return int(self.root.shape[0])
