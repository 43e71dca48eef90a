"""One factory that turns a pure compute function into a cached, checked Dagster asset.

Every stage: records its provenance (parents' data versions, settings, code
version), skips its work when that provenance equals the last one and the
stored output is intact, returns a data version computed from its own output,
attaches a preview image and counts, and reports its asset checks.
"""
from __future__ import annotations

import base64
import hashlib
import importlib
import inspect
import json
import time
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Callable

import cv2
import dagster as dg
import numpy as np

from ops.image_io import read_image, to_rgba, write_image
from ops.types import Shot
from resources.settings import PipelineSettings
from resources.shots import ShotsResource
from resources.storage import StageStore, content_hash, stored_hash

from .graph import ALL_PARENTS, SOURCES
from .provenance import INPUTS_KEY, asset_key, current_inputs, last_inputs

PARTITIONS = dg.DynamicPartitionsDefinition(name="shots")


@dataclass
class StageResult:
    value: Any
    metadata: dict = field(default_factory=dict)  # counts, energies, ... (JSON-able scalars)
    preview: np.ndarray | None = None  # (h, w, 3) float32 RGB in [0, 1]


@dataclass
class StageEnv:
    """What a compute function may read: the shot, its parents' outputs, settings, resources."""

    context: dg.AssetExecutionContext
    partition: str
    store: StageStore
    shots: ShotsResource
    settings: PipelineSettings

    @cached_property
    def shot(self) -> Shot:
        return self.shots.load(self.partition)

    def read(self, name: str) -> Any:
        return self.store.read(asset_key(name), self.partition)

    def drawing(self, k: int) -> np.ndarray:
        """(H, W, 4) float32 keyframe k."""
        return to_rgba(read_image(self.shot.keyframes[k], f"keyframes[{k}]"))

    def resource(self, name: str) -> Any:
        return getattr(self.context.resources, name)

    def log(self, message: str) -> None:
        self.context.log.info(message)


def code_version(modules: tuple[str, ...]) -> str:
    """Hash of the source of the ops modules a stage runs: editing them makes the stage stale."""
    h = hashlib.sha256()
    for m in modules:
        h.update(Path(inspect.getfile(importlib.import_module(m))).read_bytes())
    return h.hexdigest()[:12]


def stage_config(settings: PipelineSettings, uses: tuple[str, ...], modules: tuple[str, ...]) -> dict:
    return {**{k: getattr(settings, k) for k in uses}, "code": code_version(modules)}


def preview_markdown(img: np.ndarray, max_width: int = 640) -> str:
    """Inline PNG for the Dagster UI."""
    img = np.clip(img, 0, 1)
    if img.shape[1] > max_width:
        s = max_width / img.shape[1]
        img = cv2.resize(img, (max_width, max(1, int(img.shape[0] * s))), interpolation=cv2.INTER_AREA)
    bgr = cv2.cvtColor((img[..., :3] * 255 + 0.5).astype(np.uint8), cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", bgr)
    return f"![preview](data:image/png;base64,{base64.b64encode(buf.tobytes()).decode()})"


def _metadata_value(v: Any) -> Any:
    if isinstance(v, (bool, np.bool_)):
        return dg.MetadataValue.bool(bool(v))
    if isinstance(v, (int, np.integer)):
        return dg.MetadataValue.int(int(v))
    if isinstance(v, (float, np.floating)):
        return dg.MetadataValue.float(float(v))
    if isinstance(v, (list, dict, tuple)):
        return dg.MetadataValue.json(json.loads(json.dumps(v, default=str)))
    return dg.MetadataValue.text(str(v))


Check = Callable[[Any, StageEnv], tuple[bool, str]]

# stage name -> (settings it reads, ops modules whose source is its code version)
STAGE_SPECS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {}


def stage_asset(name: str, compute: Callable[[StageEnv], StageResult], *, uses: tuple[str, ...] = (),
                modules: tuple[str, ...] = (), checks: dict[str, Check] | None = None,
                resources: tuple[str, ...] = (), group: str | None = None, description: str | None = None):
    """A partitioned asset `name` whose parents come from assets.graph.PARENTS."""
    checks = checks or {}
    STAGE_SPECS[name] = (uses, modules)
    key = asset_key(name)
    check_specs = [dg.AssetCheckSpec(c, asset=key) for c in checks]
    group = group or (name.split("/")[0] if "/" in name else "blending")

    @dg.asset(key=key, deps=[asset_key(p) for p in ALL_PARENTS[name]], partitions_def=PARTITIONS,
              io_manager_key="io_manager", required_resource_keys={"io_manager", "shots", "settings", *resources},
              check_specs=check_specs, group_name=group.replace("/", "_"), description=description or compute.__doc__,
              code_version=code_version(modules) if modules else None)
    def _asset(context):
        partition = context.partition_key
        env = StageEnv(context, partition, context.resources.io_manager, context.resources.shots, context.resources.settings)
        config = stage_config(env.settings, uses, modules)
        inputs = current_inputs(context.instance, name, partition, config)
        missing = [p for p, v in inputs["parents"].items() if v is None]
        if missing:
            raise dg.Failure(f"{name}: parents {missing} have no data version for shot {partition!r}; "
                             "observe the sources first (the CLI does) or materialize the parents")
        last_version, last_recorded = last_inputs(context.instance, name, partition)
        start = time.perf_counter()
        cached = (last_recorded == inputs and last_version is not None
                  and stored_hash(env.store.path(key, partition)) == last_version)
        if cached:  # identical inputs and intact output: nothing to compute
            value = env.read(name)
            result = StageResult(value, {})
            version = last_version
        else:
            result = compute(env)
            value = result.value
            version = content_hash(value)
        seconds = time.perf_counter() - start
        meta = {INPUTS_KEY: dg.MetadataValue.text(json.dumps(inputs, sort_keys=True)),
                "seconds": dg.MetadataValue.float(round(seconds, 3)), "cached": dg.MetadataValue.bool(cached)}
        meta.update({k: _metadata_value(v) for k, v in result.metadata.items()})
        if result.preview is not None:
            preview_path = Path(env.store.root) / partition / "previews" / (name.replace("/", "__") + ".png")
            write_image(preview_path, result.preview)
            meta["preview"] = dg.MetadataValue.md(preview_markdown(result.preview))
            meta["preview_path"] = dg.MetadataValue.path(str(preview_path))
        yield dg.Output(value, data_version=dg.DataVersion(version), metadata=meta)
        for check_name, fn in checks.items():
            passed, text = fn(value, env)
            yield dg.AssetCheckResult(check_name=check_name, asset_key=key, passed=bool(passed),
                                      metadata={"detail": dg.MetadataValue.text(text)})

    return _asset


def source_assets(versions_fn: Callable[[ShotsResource, str], dict[str, str]]) -> list:
    """Observable sources whose data versions are content hashes of exactly what they cover."""
    out = []
    for name in SOURCES:
        def observe(context, shots: ShotsResource, _name=name):
            keys = [context.partition_key] if context.has_partition_key else context.instance.get_dynamic_partitions("shots")
            return dg.DataVersionsByPartition({k: dg.DataVersion(versions_fn(shots, k)[_name]) for k in keys})

        group = name.split("/")[0] if "/" in name else ("evaluation" if name == "ground_truth" else "motion")
        out.append(dg.observable_source_asset(key=asset_key(name), partitions_def=PARTITIONS, group_name=group,
                                              description=_SOURCE_DOCS[name.split("/")[-1]])(observe))
    return out


_SOURCE_DOCS = {
    "drawing": "The keyframe image and its manual masks (content hash of their bytes).",
    "pose": "The skeleton and this keyframe's pose from shot.json.",
    "t_junctions": "This keyframe's T-junction clicks from shot.json.",
    "motion": "The skeleton and every output pose and time (after interpolation).",
    "ground_truth": "The reference frames of the shot, if any (evaluation only).",
}
