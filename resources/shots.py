"""Which shot directory each partition key names.

Partition keys are shot directory names; a registry file under the storage
home maps each key to its absolute path so shots from several roots can live
in one instance (a second shot with the same name gets `name-<hash>`).
"""
from __future__ import annotations

import fcntl
import hashlib
import json
import os
from contextlib import contextmanager
from pathlib import Path

import dagster as dg
from pydantic import Field

from ops.shot import load_shot
from ops.types import Shot


@contextmanager
def _locked(path: Path):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_suffix(".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield


def _read(path: Path) -> dict[str, str]:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def register_shot(registry: Path, shot_dir: str | Path) -> str:
    """Partition key of `shot_dir`, adding it to the registry if new."""
    shot_dir = str(Path(shot_dir).resolve())
    with _locked(registry):
        reg = _read(registry)
        for key, path in reg.items():
            if path == shot_dir:
                return key
        key = Path(shot_dir).name
        if key in reg:
            key = f"{key}-{hashlib.sha256(shot_dir.encode()).hexdigest()[:6]}"
        reg[key] = shot_dir
        tmp = registry.with_suffix(f".tmp{os.getpid()}")
        tmp.write_text(json.dumps(reg, indent=1, sort_keys=True))
        os.replace(tmp, registry)
    return key


class ShotsResource(dg.ConfigurableResource):
    """Where shots live: a root scanned by the sensor, and the partition registry."""

    shots_root: str = Field(description="Directory whose sub-directories (each with shot.json) are shots.")
    registry: str = Field(description="JSON file mapping partition keys to shot directories.")

    def shot_dir(self, partition: str) -> Path:
        reg = _read(Path(self.registry))
        if partition in reg:
            return Path(reg[partition])
        return Path(self.shots_root) / partition

    def load(self, partition: str) -> Shot:
        return load_shot(self.shot_dir(partition))

    def discover(self) -> list[str]:
        """Register every shot directory under shots_root; returns their partition keys."""
        root = Path(self.shots_root)
        if not root.is_dir():
            return []
        return [register_shot(Path(self.registry), d) for d in sorted(root.iterdir()) if (d / "shot.json").is_file()]
