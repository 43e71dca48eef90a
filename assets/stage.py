"""The Dagster side of a stage: one factory that turns a declared stage (assets/compute.py, StageDef) into a cached,
checked, partitioned asset, and the observable sources.

A stage's step runs it with `run_stage` (or takes its outcome from the work-ahead, which has computed it
already), then returns its output with its data version (the content hash: an identical rerun does not make
its children stale), its counts and preview as metadata, and its asset checks. Freshness is read from the
store, not from Dagster's event log (assets/provenance.py), so the run planner decides it without Dagster.
"""
from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import dagster as dg
import numpy as np

from ops.settings import RecordingSettings, Settings
from ops.shotio.versions import source_versions
from resources.shots import ShotsResource
from resources.storage import DIGEST_KEY, PROVENANCE_KEY

from . import progress
from .codeversion import code_version
from .compute import STAGE_SPECS, MissingParents, StageDef, StageEnv, run_stage, working_ahead
from .graph import shot_graph, union_graph
from .provenance import parent_versions
from .resource_types import RESOURCE_TYPES  # noqa: F401  (the stages' resources, by key: re-exported)

PARTITIONS = dg.DynamicPartitionsDefinition(name="shots")


def asset_key(name: str) -> dg.AssetKey:
    return dg.AssetKey(name.split("/"))


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


def stage_asset(stage: StageDef):
    """A partitioned asset of the declared stage, whose lineage is its parents in any shot (assets.graph.union_graph)."""
    name, compute, checks, resources, group = stage.name, stage.compute, stage.checks, stage.resources, stage.group
    spec = STAGE_SPECS[name]
    key = asset_key(name)
    check_specs = [dg.AssetCheckSpec(c, asset=key) for c in checks]
    group = group or name.split("/")[0]

    @dg.asset(key=key, deps=[asset_key(p) for p in union_graph()[name]], partitions_def=PARTITIONS,
              io_manager_key="io_manager", required_resource_keys={"io_manager", "shots", "settings", *resources},
              check_specs=check_specs, group_name=group.replace("/", "_"), description=compute.__doc__,
              code_version=code_version(spec.code))
    def _asset(context):
        partition = context.partition_key
        settings: Settings = context.resources.settings.values()
        ahead = working_ahead(partition, name)
        try:
            if ahead is not None:  # this process's run computes its stages ahead of the steps
                outcome, env = ahead.outcome(name, context)
            else:
                env = StageEnv(context, partition, context.resources.io_manager.files, context.resources.shots,
                               RecordingSettings(settings), stage=name)
                parents = shot_graph(env.shot.n_keys).parents[name]
                outcome = run_stage(name, env, parent_versions(parents, partition, env.store,
                                                               source_versions(env.shot)), settings)
        except MissingParents as e:
            raise dg.Failure(str(e)) from None
        result, cached, seconds = outcome.result, outcome.cached, outcome.seconds
        warnings = list(result.metadata.get("warnings", []))
        cpu = round(outcome.cpu_seconds, 3)
        meta = {DIGEST_KEY: dg.MetadataValue.text(outcome.version), "seconds": dg.MetadataValue.float(round(seconds, 3)),
                "cpu_seconds": dg.MetadataValue.float(cpu), "cached": dg.MetadataValue.bool(cached)}
        if outcome.record is not None:  # the record written with the new output (resources/storage.py)
            meta[PROVENANCE_KEY] = dg.MetadataValue.text(json.dumps(outcome.record))
        meta.update({k: _metadata_value(v) for k, v in result.metadata.items()})
        if outcome.preview_md is not None:
            meta["preview"] = dg.MetadataValue.md(outcome.preview_md)
            meta["preview_path"] = dg.MetadataValue.path(str(env.store.preview_path(name, partition)))
        yield dg.Output(result.value, data_version=dg.DataVersion(outcome.version), metadata=meta)
        progress.emit(partition, name, "done", cached=cached, seconds=round(seconds, 3), cpu_seconds=cpu,
                      warnings=len(warnings))
        if checks:
            checked = env.read(name) if cached else result.value
            for check_name, fn in checks.items():
                passed, text = fn(checked, env)
                yield dg.AssetCheckResult(check_name=check_name, asset_key=key, passed=bool(passed),
                                          metadata={"detail": dg.MetadataValue.text(text)})

    return _asset


def source_asset(name: str, versions_fn: Callable[[ShotsResource, str], dict[str, str]]) -> dg.SourceAsset:
    """The observable source `name`, whose data version is a content hash of exactly what it covers."""
    def observe(context, shots: ShotsResource):
        keys = [context.partition_key] if context.has_partition_key else context.instance.get_dynamic_partitions("shots")
        # a shot of fewer keys has no such source: a fixed version, never a change
        return dg.DataVersionsByPartition({k: dg.DataVersion(versions_fn(shots, k).get(name, "absent"))
                                           for k in keys})

    group = name.split("/")[0] if "/" in name else "evaluation"  # ground_truth
    return dg.observable_source_asset(key=asset_key(name), partitions_def=PARTITIONS, group_name=group,
                                      description=_SOURCE_DOCS[name.split("/")[-1]])(observe)


_SOURCE_DOCS = {
    "drawing": "The keyframe image and its manual masks (content hash of their bytes).",
    "pose": "The skeleton and this keyframe's pose from shot.json.",
    "t_junctions": "This keyframe's T-junction clicks from shot.json.",
    "motion": "The skeleton and the pose and local time of every frame of this segment (after interpolation).",
    "ground_truth": "The reference frames of the shot, if any (evaluation only).",
}
