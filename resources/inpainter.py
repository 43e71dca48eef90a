"""The inpainter as a Dagster resource.

The default is OpenCV's inpainting. To plug in a learned inpainter, subclass
InpainterResource and override get() to return any callable with the
ops.inpaint.Inpainter signature ``(image (H, W, 3) float32, hole (H, W) bool)
-> (H, W, 3) float32``, e.g.::

    class LamaInpainterResource(InpainterResource):
        weights: str
        def get(self) -> Inpainter:
            return LamaInpainter(self.weights)   # loads the model once

and bind it under the same resource key ("inpainter") in the Definitions.
"""
from __future__ import annotations

from dagster import ConfigurableResource

from ops.appearance.inpaint import Inpainter, OpenCVInpainter


class InpainterResource(ConfigurableResource):
    """Which inpainter fills pocket texture that no keyframe shows (§5.1)."""

    method: str = "telea"  # "telea" | "ns" (cv2.inpaint)
    radius: int = 5  # neighbourhood radius, pixels

    def get(self) -> Inpainter:
        """The inpainter callable (validates method and radius)."""
        return OpenCVInpainter(radius=self.radius, method=self.method)
