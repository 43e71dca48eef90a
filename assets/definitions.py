"""The Dagster Definitions: assets of both lanes and the blending, resources, sensor, jobs, loggers.

Paths come from the environment so the UI (`dagster dev -w workspace.yaml`)
and the `inbetween` CLI share one instance and one storage (assets/home.py):
  INBETWEEN_HOME   default ./.inbetween  (dagster/ = DAGSTER_HOME, storage/, shots.json)
  INBETWEEN_SHOTS  default ./data_samples (scanned by the sensor)

Where the `.[farm]` extra is installed, the job `inbetween_shot_farm` runs
the same stages with each step on a Celery worker (assets/farm/,
docs/production.md).
"""
from __future__ import annotations

import functools
import logging
from collections.abc import Collection
from importlib.util import find_spec
from pathlib import Path

import dagster as dg

from ops.settings import Settings
from ops.shotio.versions import source_versions
from resources.settings import PipelineSettings
from resources.shots import ShotsResource
from resources.storage import StageStore

from .codeversion import project_fingerprint
from .graph import EVAL_STAGES, union_sources
from .home import home, shots_root
from .resource_config import resource_config, resource_overrides
from .resource_types import RESOURCE_TYPES, model_resources
from .stage import PARTITIONS, asset_key, source_asset, stage_asset
from .stages import EVALUATION_STAGES, SHOT_STAGES

# the sources this process defines its stages from (assets/run/ compares it with the files on disk)
LOADED_FINGERPRINT = project_fingerprint()


def build_resources(settings: Settings | None = None) -> dict:
    h = home()
    return {
        "io_manager": StageStore(root=str(h / "storage")),
        "shots": ShotsResource(shots_root=str(shots_root()), registry=str(h / "shots.json")),
        "settings": PipelineSettings(**(settings or Settings()).as_dict()),
        # configured from the environment (assets/resource_config.py); every stage records what it used
        **model_resources(),
    }


def resources_config(settings: Settings | None = None) -> dict:
    """Run config that pins a run's resources to this process's home, shots and settings.

    A farm run's steps build their resources on other hosts: this config travels with the run, so they
    write where the process that planned the run will read, with the settings and the models it planned for. Every field
    is given: a resource configured in the run config keeps none of its values from the Definitions.
    """
    h = home()
    models = {key: {"config": {f: v for f, v in resource_config(kind(**resource_overrides().get(key, {}))).items()
                               if v is not None}}
              for key, kind in RESOURCE_TYPES.items()}  # the RIFE weights and the inpainter it planned with
    return {"io_manager": {"config": {"root": str(h / "storage")}},
            "shots": {"config": {"shots_root": str(shots_root()), "registry": str(h / "shots.json")}},
            "settings": {"config": (settings or Settings()).as_dict()}, **models}


def _versions(shots: ShotsResource, partition: str) -> dict[str, str]:
    return source_versions(shots.load(partition))


# every stage any shot can have: a lane per key, each segment's two sides and its blending (assets/stages.py)
SHOT_SELECTION = dg.AssetSelection.assets(*(asset_key(d.name) for d in SHOT_STAGES))


_STAGE_DEFS = {d.name: d for d in (*SHOT_STAGES, *EVALUATION_STAGES)}


@functools.cache
def _source(name: str) -> dg.SourceAsset:
    """The observable source asset `name`, made on first use."""
    return source_asset(name, _versions)


@functools.cache
def _stage(name: str) -> dg.AssetsDefinition:
    """The asset of stage `name`, made on first use: a run makes its shot's alone (about 5 ms each, most of it
    Dagster reading the step function's signature), not all of them."""
    return stage_asset(_STAGE_DEFS[name])


def _sources() -> dict[str, dg.SourceAsset]:
    """Every source any shot can have, as an observable source asset, by name."""
    return {n: _source(n) for n in union_sources()}


def _stage_assets() -> dict[str, dg.AssetsDefinition]:
    """Every stage's asset (the shots' and the evaluation group's), by name."""
    return {n: _stage(n) for n in _STAGE_DEFS}


def __getattr__(name: str):
    """The UI's Definitions (`defs`: every stage of every shot size, 172 assets) and their asset lists, made on
    first use: a run builds only its shot's (`shot_definitions`)."""
    if name == "defs":
        globals()["defs"] = value = build_definitions()
        return value
    if name == "SOURCE_ASSETS":
        return list(_sources().values())
    if name == "SHOT_ASSETS":
        return [_stage_assets()[d.name] for d in SHOT_STAGES]
    if name == "STAGE_ASSETS":
        return list(_stage_assets().values())
    if name == "ALL_ASSETS":
        return [*_sources().values(), *_stage_assets().values()]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# the jobs' partitions come from their assets (the shots' dynamic partitions)
# observing a shot's sources hashes a few files: in one process (the default multiprocess executor would start an
# interpreter per source asset, 64 of them, for every shot the sensor finds)
observe_job = dg.define_asset_job("observe_sources", selection=[asset_key(s) for s in union_sources()],
                                  executor_def=dg.in_process_executor)
shot_job = dg.define_asset_job("inbetween_shot", selection=SHOT_SELECTION)
evaluation_job = dg.define_asset_job("evaluate_shot", selection=[asset_key(n) for n in EVAL_STAGES])
FARM_JOB = "inbetween_shot_farm"


def farm_jobs() -> list:
    """The shot job on the Celery executor (assets/farm/), where the `.[farm]` extra is installed."""
    if find_spec("dagster_celery") is None:  # no dagster-celery: every other path works without it
        return []
    from .farm.executor import farm_executor  # imports dagster-celery only when a farm run starts
    return [dg.define_asset_job(FARM_JOB, selection=SHOT_SELECTION, executor_def=farm_executor)]


@dg.sensor(job=observe_job, minimum_interval_seconds=30, default_status=dg.DefaultSensorStatus.RUNNING)
def shot_directories(context: dg.SensorEvaluationContext, shots: ShotsResource):
    """Adds a partition for every shot directory under the shots root and observes its sources."""
    known = set(context.instance.get_dynamic_partitions("shots"))
    found = shots.discover()
    new = [k for k in found if k not in known]
    return dg.SensorResult(run_requests=[dg.RunRequest(partition_key=k, run_key=f"observe-{k}") for k in new],
                           dynamic_partitions_requests=[PARTITIONS.build_add_request(new)] if new else [])


@dg.logger({"path": dg.Field(str, is_required=False), "log_level": dg.Field(str, default_value="DEBUG")},
           description="Dagster's event log of a run as text, in a file (the CLI prints its path on failure).")
def file_logger(init_context: dg.InitLoggerContext) -> logging.Logger:
    path = Path(init_context.logger_config.get("path") or home() / "logs" / "dagster.log")
    path.parent.mkdir(parents=True, exist_ok=True)
    log = logging.getLogger(f"inbetween.file.{path}")
    log.setLevel(init_context.logger_config["log_level"])
    log.propagate = False  # the file only: the console logger decides what the terminal shows
    if not log.handlers:
        handler = logging.FileHandler(path)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        log.addHandler(handler)
    return log


LOGGERS = {"console": dg.colored_console_logger, "file": file_logger}


def build_definitions(settings: Settings | None = None) -> dg.Definitions:
    """Everything: the assets of every stage of every shot size, the jobs, the sensor (the UI's, the farm's)."""
    return dg.Definitions(assets=[*_sources().values(), *_stage_assets().values()],
                          jobs=[observe_job, shot_job, evaluation_job, *farm_jobs()],
                          sensors=[shot_directories], resources=build_resources(settings), loggers=LOGGERS)


def shot_definitions(stages: Collection[str], sources: Collection[str],
                     settings: Settings | None = None) -> dg.Definitions:
    """The assets of `stages` and `sources` alone (a shot's graph, assets.graph.ShotGraph), with the resources
    and loggers of `build_definitions`: what one run of an in-process executor needs. Its asset keys, code
    versions and lineage are the full Definitions' (a stage's parents in a shot of another size stay outside,
    as external assets), so what it records is what the UI reads."""
    return dg.Definitions(assets=[*(_source(n) for n in sources), *(_stage(n) for n in stages)],
                          resources=build_resources(settings), loggers=LOGGERS)


def farm_job() -> dg.JobDefinition:
    """The farm job, for `dg.reconstructable`: a Celery worker rebuilds it by importing this module."""
    return __getattr__("defs").resolve_job_def(FARM_JOB)
