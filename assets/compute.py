"""What a stage is and how it runs, without Dagster: its compute function, the environment it reads through, its
code record, and `run_stage`, which decides freshness from the store and computes when needed.

Every stage: records its provenance with its output (its parents' data versions, the settings it read, its
code record, its resources' configuration), skips its work when that provenance equals what the inputs are now
and the stored output is intact, returns the content hash of its output as its data version, and writes a
preview image. The asset modules (geometry, blending, evaluation) declare their stages here as `StageDef`s;
assets/stage.py turns each into a Dagster asset, and the work-ahead (assets/ahead.py) runs them before Dagster
has even been imported (a run starts computing while Dagster and the Definitions load: about 2.5 s).
"""
from __future__ import annotations

import base64
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import cv2
import numpy as np

from ops.cputime import charged
from ops.settings import RecordingSettings, Settings
from ops.shotio.image_io import read_image, to_rgba, write_image
from ops.types import Shot
from resources.store import Store, content_hash

from . import processes, progress
from .codeversion import code_record
from .provenance import differences, provenance
from .resource_config import resource_config

# the resources a stage may declare, by key, and the modules that define them (their code is in the stage's code
# record); assets/stage.py holds their Dagster classes (tests/assets/test_stage_registry.py checks the two agree)
RESOURCE_MODULES: dict[str, str] = {"rife": "resources.rife", "inpainter": "resources.inpainter"}


class MissingParents(RuntimeError):
    """A stage's parents have no stored output: they must be materialized first."""


@dataclass
class StageResult:
    value: Any
    metadata: dict = field(default_factory=dict)  # counts, energies, ... (JSON-able scalars)
    preview: np.ndarray | None = None  # (h, w, 3) float32 RGB in [0, 1]


@dataclass
class StageEnv:
    """What a compute function may read: the shot, its parents' outputs, settings, resources."""

    context: Any  # a Dagster AssetExecutionContext, or the work-ahead's stand-in: .resources and .log
    partition: str
    store: Store
    shots: Any  # resources.shots.ShotsResource (not read where the shot is given)
    settings: RecordingSettings
    memory: dict[str, Any] = field(default_factory=dict)  # outputs this run already computed, by stage
    stage: str = ""  # the stage this environment computes
    parallel: bool = False  # op calls go to worker processes (assets/processes.py): the work-ahead's runs
    code: dict[str, str] | None = None  # the stage's code record as run_stage compares it (None: not set yet)

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


Check = Callable[[Any, StageEnv], tuple[bool, str]]


@dataclass(frozen=True)
class StageDef:
    """A stage as an asset module declares it: its name, what computes it, its checks and resources."""

    name: str
    compute: Callable[[StageEnv], StageResult]
    checks: dict[str, Check] = field(default_factory=dict)
    resources: tuple[str, ...] = ()
    group: str | None = None  # the Dagster asset group (default: the name's first part)


@dataclass
class StageSpec:
    """What the planner and a run need of a stage without Dagster: its compute function, its code record."""

    name: str
    functions: tuple[Callable, ...]  # the compute function and the StageEnv methods it reads through
    resource_modules: tuple[str, ...]  # modules of the resources it declares
    resources: tuple[str, ...] = ()  # the keys of those resources

    @property
    def compute(self) -> Callable[[StageEnv], StageResult]:
        return self.functions[0]

    @cached_property
    def code(self) -> dict[str, str]:
        """file -> source hash of what the stage runs (assets/codeversion.py), once per compute function's code."""
        return _code_record(self.compute.__code__, self.functions, self.resource_modules)


# stage name -> spec, filled as the asset modules declare their stages
STAGE_SPECS: dict[str, StageSpec] = {}


def stage(name: str, compute: Callable[[StageEnv], StageResult], *, checks: dict[str, Check] | None = None,
          resources: tuple[str, ...] = (), group: str | None = None) -> StageDef:
    """Declare stage `name` (registered in STAGE_SPECS) -> its StageDef, for assets/stage.py to make an asset of."""
    unknown = set(resources) - set(RESOURCE_MODULES)
    if unknown:
        raise ValueError(f"stage {name} declares unknown resources {sorted(unknown)}")
    functions = (compute, *[v for v in vars(StageEnv).values() if callable(v)], StageEnv.shot.func)
    STAGE_SPECS[name] = StageSpec(name, functions, tuple(RESOURCE_MODULES[r] for r in resources), tuple(resources))
    return StageDef(name, compute, dict(checks or {}), tuple(resources), group)


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
    cpu_seconds: float = 0.0  # CPU of the stage's thread and what it handed off (ops.cputime)


# metadata a stage's provenance keeps beside its warnings, for the run's report: the lanes' agreement with the
# other key (report.json's segments, `lane_agreement_db`)
RECORDED_METRICS = ("agreement_db",)


def run_stage(name: str, env: StageEnv, parents: dict[str, str | None], settings: Settings,
              code: dict[str, str] | None = None) -> Outcome:
    """Compute stage `name` unless its stored output was made from exactly these parents' data versions, the
    settings it read and its code (`code`: its record, when the caller has it; else computed); write its preview.
    Pure of Dagster: it may run ahead of the step that records it (assets/ahead.py)."""
    spec = STAGE_SPECS[name]
    missing = [p for p, v in parents.items() if v is None]
    if missing:
        raise MissingParents(f"{name}: parents {missing} have no stored output for shot {env.partition!r}; "
                             "materialize them first (the CLI selects them)")
    code = spec.code if code is None else code
    progress.emit(env.partition, name, "start")
    start, thread_cpu, elsewhere = time.perf_counter(), time.thread_time(), charged()
    version, recorded = env.store.provenance(name, env.partition)
    resources = {r: resource_config(env.resource(r)) for r in spec.resources}
    cached = version is not None and not differences(recorded, parents, settings, code, resources)
    record = None
    if cached:  # identical inputs and intact output: nothing to compute, nothing to write
        result = StageResult(None, {"warnings": (recorded or {}).get("warnings", [])})
    else:
        env.code = code  # the record the stored output is judged by, for a stage that reuses its own (the template)
        result = spec.compute(env)
        version = content_hash(result.value)
        record = {**provenance(parents, env.settings.read, code, resources),
                  "warnings": list(result.metadata.get("warnings", []))}
        metrics = {k: result.metadata[k] for k in RECORDED_METRICS if k in result.metadata}
        if metrics:
            record["metrics"] = metrics
    seconds = time.perf_counter() - start
    cpu = time.thread_time() - thread_cpu + charged() - elsewhere
    preview_md = None
    if result.preview is not None:
        write_image(env.store.preview_path(name, env.partition), result.preview)
        preview_md = preview_markdown(result.preview)
    return Outcome(version, cached, result, seconds, record, preview_md, cpu)


def preview_markdown(img: np.ndarray, max_width: int = 640) -> str:
    """Inline PNG for the Dagster UI."""
    img = np.clip(img, 0, 1)
    if img.shape[1] > max_width:
        s = max_width / img.shape[1]
        img = cv2.resize(img, (max_width, max(1, int(img.shape[0] * s))), interpolation=cv2.INTER_AREA)
    bgr = cv2.cvtColor((img[..., :3] * 255 + 0.5).astype(np.uint8), cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", bgr)
    return f"![preview](data:image/png;base64,{base64.b64encode(buf.tobytes()).decode()})"


# this process's work-ahead per partition while a run executes (assets/ahead.py registers itself here)
AHEAD: dict[str, Any] = {}


def working_ahead(partition: str, name: str) -> Any:
    """The work-ahead that computes stage `name` of this partition's current run in this process, or None."""
    ahead = AHEAD.get(partition)
    return ahead if ahead is not None and name in ahead.names else None
