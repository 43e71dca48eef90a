"""The Dagster Definitions: assets of both lanes and the blending, resources, sensor, jobs.

Paths come from the environment so the UI (`dagster dev -w workspace.yaml`)
and the `inbetween` CLI share one instance and one storage:
  INBETWEEN_HOME   default ./.inbetween  (dagster/ = DAGSTER_HOME, storage/, shots.json)
  INBETWEEN_SHOTS  default ./data_samples (scanned by the sensor)
"""
from __future__ import annotations

import os
from pathlib import Path

import dagster as dg

from ops.shot import source_versions
from resources.inpainter import InpainterResource
from resources.rife import RifeResource
from resources.settings import PipelineSettings
from resources.shots import ShotsResource
from resources.storage import StageStore

from .blending import blending_assets
from .evaluation import evaluation_assets
from .geometry import lane_assets
from .graph import EVAL_STAGES, SOURCES
from .provenance import asset_key
from .stage import PARTITIONS, source_assets

DAGSTER_YAML = """\
# Written by inbetween: local SQLite storage, no telemetry. See docs/production.md for Postgres.
telemetry:
  enabled: false
"""


def home() -> Path:
    return Path(os.environ.get("INBETWEEN_HOME", Path.cwd() / ".inbetween")).resolve()


def ensure_home() -> Path:
    """Create the project-local home and point DAGSTER_HOME at it unless the user set one."""
    h = home()
    dh = Path(os.environ.setdefault("DAGSTER_HOME", str(h / "dagster")))
    dh.mkdir(parents=True, exist_ok=True)
    if not (dh / "dagster.yaml").exists():
        (dh / "dagster.yaml").write_text(DAGSTER_YAML)
    return h


def build_resources(settings: PipelineSettings | None = None) -> dict:
    h = home()
    return {
        "io_manager": StageStore(root=str(h / "storage")),
        "shots": ShotsResource(shots_root=str(Path(os.environ.get("INBETWEEN_SHOTS", "data_samples")).resolve()),
                               registry=str(h / "shots.json")),
        "settings": settings or PipelineSettings(),
        "rife": RifeResource(device=os.environ.get("INBETWEEN_DEVICE", "cpu")),
        "inpainter": InpainterResource(),
    }


def _versions(shots: ShotsResource, partition: str) -> dict[str, str]:
    return source_versions(shots.load(partition))


SOURCE_ASSETS = source_assets(_versions)
STAGE_ASSETS = [*lane_assets(0), *lane_assets(1), *blending_assets(), *evaluation_assets()]
ALL_ASSETS = [*SOURCE_ASSETS, *STAGE_ASSETS]

observe_job = dg.define_asset_job("observe_sources", selection=[asset_key(s) for s in SOURCES],
                                  partitions_def=PARTITIONS)
shot_job = dg.define_asset_job("inbetween_shot", selection=dg.AssetSelection.groups("key0", "key1", "blending"),
                               partitions_def=PARTITIONS)
evaluation_job = dg.define_asset_job("evaluate_shot", selection=[asset_key(n) for n in EVAL_STAGES],
                                     partitions_def=PARTITIONS)


@dg.sensor(job=observe_job, minimum_interval_seconds=30, default_status=dg.DefaultSensorStatus.RUNNING)
def shot_directories(context: dg.SensorEvaluationContext, shots: ShotsResource):
    """Adds a partition for every shot directory under the shots root and observes its sources."""
    known = set(context.instance.get_dynamic_partitions("shots"))
    found = shots.discover()
    new = [k for k in found if k not in known]
    return dg.SensorResult(run_requests=[dg.RunRequest(partition_key=k, run_key=f"observe-{k}") for k in new],
                           dynamic_partitions_requests=[PARTITIONS.build_add_request(new)] if new else [])


def build_definitions(settings: PipelineSettings | None = None) -> dg.Definitions:
    return dg.Definitions(assets=ALL_ASSETS, jobs=[observe_job, shot_job, evaluation_job], sensors=[shot_directories],
                          resources=build_resources(settings))


defs = build_definitions()
