"""The inpainter as a Dagster resource.

`method` picks how pocket texture that no keyframe shows is filled: "auto" (per connected hole: flat colour
with its strokes continued where the surroundings are flat, OpenCV's Telea where they are textured), "flat"
(every hole flat), "telea" or "ns" (cv2.inpaint). To plug in a learned inpainter, subclass
InpainterResource and override get() to return any callable with the ops.appearance.inpaint.Inpainter
signature ``(image (H, W, 3) float32, hole (H, W) bool[, coverage (H, W) float32]) -> (H, W, 3) float32``,
e.g.::

    class LamaInpainterResource(InpainterResource):
        weights: str
        def get(self) -> Inpainter:
            return LamaInpainter(self.weights)   # loads the model once

and bind it under the same resource key ("inpainter") in the Definitions.
"""
from __future__ import annotations

from dagster import ConfigurableResource

from ops.appearance.inpaint import Inpainter, make_inpainter


class InpainterResource(ConfigurableResource):
    """Which inpainter fills pocket texture that no keyframe shows (§5.1)."""

    method: str = "telea"  # "auto" | "flat" | "telea" | "ns" (ops.appearance.inpaint.INPAINT_METHODS)
    radius: int = 5  # Telea / Navier-Stokes neighbourhood radius, pixels

    def get(self) -> Inpainter:
        """The inpainter callable (validates method and radius)."""
        return make_inpainter(self.method, self.radius)
