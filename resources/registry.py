"""Which shot directory each partition key names.

Partition keys are shot directory names; a registry file under the storage
home maps each key to its absolute path so shots from several roots can live
in one instance (a second shot with the same name gets `name-<hash>`).
No Dagster here: the run planner reads it before deciding whether to start Dagster.
"""
from __future__ import annotations

import fcntl
import hashlib
import json
import os
from contextlib import contextmanager
from pathlib import Path


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


def partition_of(registry: Path, shot_dir: str | Path) -> str | None:
    """Partition key the registry gives `shot_dir`, or None when it has none (nothing written)."""
    shot_dir = str(Path(shot_dir).resolve())
    return next((key for key, path in _read(registry).items() if path == shot_dir), None)


def register_shot(registry: Path, shot_dir: str | Path) -> str:
    """Partition key of `shot_dir`, adding it to the registry if new."""
    known = partition_of(registry, shot_dir)  # known already: no lock, no write
    if known is not None:
        return known
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


def lookup(registry: Path, partition: str) -> Path | None:
    """Shot directory of a partition key, or None when the registry does not name it."""
    path = _read(registry).get(partition)
    return Path(path) if path else None


def discover(registry: Path, root: Path) -> list[str]:
    """Register every shot directory (with shot.json) under root; returns their partition keys."""
    if not root.is_dir():
        return []
    return [register_shot(registry, d) for d in sorted(root.iterdir()) if (d / "shot.json").is_file()]
