"""One factory that turns a pure compute function into a cached, checked Dagster asset.

Every stage: records its provenance with its output (its parents' data
versions, the settings it read, its code record), skips its work when that
provenance equals what the inputs are now and the stored output is intact,
returns the content hash of its output as its data version, attaches a
preview image and counts, and reports its asset checks. Freshness is read
from the store, not from Dagster's event log (assets/provenance.py), so the
run planner can decide it without starting Dagster.
"""
from __future__ import annotations

import base64
import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import cv2
import dagster as dg
import numpy as np

from ops.settings import RecordingSettings, Settings
from ops.shotio.image_io import read_image, to_rgba, write_image
from ops.shotio.versions import source_versions
from ops.types import Shot
from resources.inpainter import InpainterResource
from resources.rife import RifeResource
from resources.shots import ShotsResource
from resources.storage import DIGEST_KEY, PROVENANCE_KEY
from resources.store import Store, content_hash

from . import processes, progress
from .codeversion import code_record, code_version
from .graph import shot_graph, union_graph, union_sources
from .provenance import differences, parent_versions, provenance
from .resource_config import resource_config

PARTITIONS = dg.DynamicPartitionsDefinition(name="shots")

# the resources a stage may declare, by key: their modules' code is part of the stage's code record
RESOURCE_TYPES: dict[str, type] = {"rife": RifeResource, "inpainter": InpainterResource}


def asset_key(name: str) -> dg.AssetKey:
    return dg.AssetKey(name.split("/"))


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
    store: Store
    shots: ShotsResource
    settings: RecordingSettings
    memory: dict[str, Any] = field(default_factory=dict)  # outputs this run already computed, by stage
    stage: str = ""  # the stage this environment computes
    parallel: bool = False  # op calls go to worker processes (assets/processes.py): the work-ahead's runs

    @cached_property
    def shot(self) -> Shot:
        return self.shots.load(self.partition)

    def read(self, name: str) -> Any:
        if name in self.memory:  # computed earlier in this run: no read back from disk
            return self.memory[name]
        return self.store.read(name, self.partition)

    def drawing(self, k: int) -> np.ndarray:
        """(H, W, 4) float32 keyframe k."""
        return to_rgba(read_image(self.shot.keyframes[k], f"keyframes[{k}]"))

    def resource(self, name: str) -> Any:
        return getattr(self.context.resources, name)

    def log(self, message: str) -> None:
        self.context.log.info(message)

    def offload(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """fn(*args, **kwargs) for an ops function fn: in a worker process when this run has them."""
        return processes.run(fn, *args, **kwargs) if self.parallel else fn(*args, **kwargs)


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


@dataclass(frozen=True)
class StageSpec:
    """What the planner needs of a stage without running it: its code record, and what it was derived from."""

    name: str
    code: dict[str, str]  # file -> source hash (assets/codeversion.py)
    functions: tuple[Callable, ...]  # the compute function and the StageEnv methods it reads through
    resource_modules: tuple[str, ...]  # modules of the resources it declares
    resources: tuple[str, ...] = ()  # the keys of those resources

    @property
    def compute(self) -> Callable[[StageEnv], StageResult]:
        return self.functions[0]


# stage name -> spec, filled as the asset modules define their stages
STAGE_SPECS: dict[str, StageSpec] = {}


def stage_spec(name: str, compute: Callable, resources: tuple[str, ...]) -> StageSpec:
    """Code record of a stage: its compute function, the StageEnv it reads through, its resources' modules."""
    functions = (compute, *[v for v in vars(StageEnv).values() if callable(v)], StageEnv.shot.func)
    modules = tuple(RESOURCE_TYPES[r].__module__ for r in resources)
    return StageSpec(name, _code_record(compute.__code__, functions, modules), functions, modules, tuple(resources))


_RECORDS: dict[tuple, dict[str, str]] = {}


def _code_record(code, functions: tuple[Callable, ...], modules: tuple[str, ...]) -> dict[str, str]:
    """code_record, once per compute function's code: every key's lane (a closure over k) runs the same code."""
    key = (code, modules)
    if key not in _RECORDS:
        _RECORDS[key] = code_record(functions, modules)
    return _RECORDS[key]


@dataclass
class Outcome:
    """What running a stage gave: its output (value None when the stored one still holds), and its record."""

    version: str  # content hash of the output: the data version
    cached: bool  # the stored output's provenance equals the inputs': nothing computed, nothing to write
    result: StageResult
    seconds: float
    record: dict | None  # provenance to store with a new output (None when cached)
    preview_md: str | None  # the preview as inline markdown for the UI


def run_stage(name: str, env: StageEnv, parents: dict[str, str | None], settings: Settings) -> Outcome:
    """Compute stage `name` unless its stored output was made from exactly these parents' data versions, the
    settings it read and its code; write its preview. Pure of Dagster's run machinery: it may run ahead of the
    step that records it (assets/ahead.py)."""
    spec = STAGE_SPECS[name]
    missing = [p for p, v in parents.items() if v is None]
    if missing:
        raise dg.Failure(f"{name}: parents {missing} have no stored output for shot {env.partition!r}; "
                         "materialize them first (the CLI selects them)")
    progress.emit(env.partition, name, "start")
    start = time.perf_counter()
    version, recorded = env.store.provenance(name, env.partition)
    resources = {r: resource_config(env.resource(r)) for r in spec.resources}
    cached = version is not None and not differences(recorded, parents, settings, spec.code, resources)
    record = None
    if cached:  # identical inputs and intact output: nothing to compute, nothing to write
        result = StageResult(None, {"warnings": (recorded or {}).get("warnings", [])})
    else:
        result = spec.compute(env)
        version = content_hash(result.value)
        record = {**provenance(parents, env.settings.read, spec.code, resources),
                  "warnings": list(result.metadata.get("warnings", []))}
    seconds = time.perf_counter() - start
    preview_md = None
    if result.preview is not None:
        write_image(env.store.preview_path(name, env.partition), result.preview)
        preview_md = preview_markdown(result.preview)
    return Outcome(version, cached, result, seconds, record, preview_md)


# this process's work-ahead per partition while a run executes (assets/ahead.py registers itself here)
AHEAD: dict[str, Any] = {}


def working_ahead(partition: str, name: str) -> Any:
    """The work-ahead that computes stage `name` of this partition's current run in this process, or None."""
    ahead = AHEAD.get(partition)
    return ahead if ahead is not None and name in ahead.names else None


def stage_asset(name: str, compute: Callable[[StageEnv], StageResult], *, checks: dict[str, Check] | None = None,
                resources: tuple[str, ...] = (), group: str | None = None, description: str | None = None):
    """A partitioned asset `name` whose lineage is its parents in any shot (assets.graph.union_graph)."""
    checks = checks or {}
    STAGE_SPECS[name] = spec = stage_spec(name, compute, resources)
    key = asset_key(name)
    check_specs = [dg.AssetCheckSpec(c, asset=key) for c in checks]
    group = group or name.split("/")[0]

    @dg.asset(key=key, deps=[asset_key(p) for p in union_graph()[name]], partitions_def=PARTITIONS,
              io_manager_key="io_manager", required_resource_keys={"io_manager", "shots", "settings", *resources},
              check_specs=check_specs, group_name=group.replace("/", "_"), description=description or compute.__doc__,
              code_version=code_version(spec.code))
    def _asset(context):
        partition = context.partition_key
        settings: Settings = context.resources.settings.values()
        ahead = working_ahead(partition, name)
        if ahead is not None:  # this process's run computes its stages ahead of the steps
            outcome, env = ahead.outcome(name, context)
        else:
            env = StageEnv(context, partition, context.resources.io_manager.files, context.resources.shots,
                           RecordingSettings(settings), stage=name)
            parents = shot_graph(env.shot.n_keys).parents[name]
            outcome = run_stage(name, env, parent_versions(parents, partition, env.store, source_versions(env.shot)),
                                settings)
        result, cached, seconds = outcome.result, outcome.cached, outcome.seconds
        warnings = list(result.metadata.get("warnings", []))
        meta = {DIGEST_KEY: dg.MetadataValue.text(outcome.version), "seconds": dg.MetadataValue.float(round(seconds, 3)),
                "cached": dg.MetadataValue.bool(cached)}
        if outcome.record is not None:  # the record written with the new output (resources/storage.py)
            meta[PROVENANCE_KEY] = dg.MetadataValue.text(json.dumps(outcome.record))
        meta.update({k: _metadata_value(v) for k, v in result.metadata.items()})
        if outcome.preview_md is not None:
            meta["preview"] = dg.MetadataValue.md(outcome.preview_md)
            meta["preview_path"] = dg.MetadataValue.path(str(env.store.preview_path(name, partition)))
        yield dg.Output(result.value, data_version=dg.DataVersion(outcome.version), metadata=meta)
        progress.emit(partition, name, "done", cached=cached, seconds=round(seconds, 3), warnings=len(warnings))
        if checks:
            checked = env.read(name) if cached else result.value
            for check_name, fn in checks.items():
                passed, text = fn(checked, env)
                yield dg.AssetCheckResult(check_name=check_name, asset_key=key, passed=bool(passed),
                                          metadata={"detail": dg.MetadataValue.text(text)})

    return _asset


def source_assets(versions_fn: Callable[[ShotsResource, str], dict[str, str]]) -> list:
    """Observable sources whose data versions are content hashes of exactly what they cover."""
    out = []
    for name in union_sources():
        def observe(context, shots: ShotsResource, _name=name):
            keys = [context.partition_key] if context.has_partition_key else context.instance.get_dynamic_partitions("shots")
            # a shot of fewer keys has no such source: a fixed version, never a change
            return dg.DataVersionsByPartition({k: dg.DataVersion(versions_fn(shots, k).get(_name, "absent"))
                                               for k in keys})

        group = name.split("/")[0] if "/" in name else "evaluation"  # ground_truth
        out.append(dg.observable_source_asset(key=asset_key(name), partitions_def=PARTITIONS, group_name=group,
                                              description=_SOURCE_DOCS[name.split("/")[-1]])(observe))
    return out


_SOURCE_DOCS = {
    "drawing": "The keyframe image and its manual masks (content hash of their bytes).",
    "pose": "The skeleton and this keyframe's pose from shot.json.",
    "t_junctions": "This keyframe's T-junction clicks from shot.json.",
    "motion": "The skeleton and the pose and local time of every frame of this segment (after interpolation).",
    "ground_truth": "The reference frames of the shot, if any (evaluation only).",
}
