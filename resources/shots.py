"""Where shots live, as a Dagster resource: the root the sensor scans and the partition registry."""
from __future__ import annotations

from pathlib import Path

import dagster as dg
from pydantic import Field

from ops.shotio.load import load_shot
from ops.types import Shot

from .registry import discover, lookup


class ShotsResource(dg.ConfigurableResource):
    """Where shots live: a root scanned by the sensor, and the partition registry."""

    shots_root: str = Field(description="Directory whose sub-directories (each with shot.json) are shots.")
    registry: str = Field(description="JSON file mapping partition keys to shot directories.")

    def shot_dir(self, partition: str) -> Path:
        return lookup(Path(self.registry), partition) or Path(self.shots_root) / partition

    def load(self, partition: str) -> Shot:
        return load_shot(self.shot_dir(partition))

    def discover(self) -> list[str]:
        """Register every shot directory under shots_root; returns their partition keys."""
        return discover(Path(self.registry), Path(self.shots_root))
