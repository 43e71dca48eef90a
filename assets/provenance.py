"""Data versions and staleness, read from the Dagster event log.

Each stage records, with its materialization, the data versions of its
parents plus its settings and code version (metadata `inbetween/inputs`).
A stage is fresh when those equal the parents' current versions, so a
parent re-executed with an identical result leaves its children fresh.
We keep this record ourselves because Dagster 1.13 does not record the
per-partition data version of an observable source as an input version.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

import dagster as dg

from .graph import ALL_PARENTS, SOURCES, STAGES, descendants

INPUTS_KEY = "inbetween/inputs"


def asset_key(name: str) -> dg.AssetKey:
    return dg.AssetKey(name.split("/"))


def current_version(instance: dg.DagsterInstance, name: str, partition: str) -> str | None:
    """Latest data version of a source (observation) or stage (materialization) for a partition."""
    flt = dg.AssetRecordsFilter(asset_key=asset_key(name), asset_partitions=[partition])
    fetch = instance.fetch_observations if name in SOURCES else instance.fetch_materializations
    records = fetch(flt, limit=1).records
    if not records:
        return None
    event = records[0].asset_observation if name in SOURCES else records[0].asset_materialization
    return event.tags.get("dagster/data_version")


def last_inputs(instance: dg.DagsterInstance, name: str, partition: str) -> tuple[str | None, dict | None]:
    """(data version, recorded inputs) of a stage's latest materialization for a partition."""
    records = instance.fetch_materializations(
        dg.AssetRecordsFilter(asset_key=asset_key(name), asset_partitions=[partition]), limit=1).records
    if not records:
        return None, None
    mat = records[0].asset_materialization
    entry = mat.metadata.get(INPUTS_KEY)
    return mat.tags.get("dagster/data_version"), (json.loads(entry.value) if entry is not None else None)


def current_inputs(instance: dg.DagsterInstance, name: str, partition: str, config: dict) -> dict:
    """What a stage would record if it ran now: parents' versions + its config."""
    return {"parents": {p: current_version(instance, p, partition) for p in ALL_PARENTS[name]}, "config": config}


@dataclass
class StageStatus:
    name: str
    state: str  # "fresh" | "stale" | "missing"
    causes: list[str]


def resolve(instance: dg.DagsterInstance, partition: str, configs: dict[str, dict], exists,
            stages: tuple[str, ...] = STAGES) -> dict[str, StageStatus]:
    """Status of each stage (one hop, as Dagster computes it). `exists(name)` checks storage."""
    out = {}
    for name in stages:
        version, recorded = last_inputs(instance, name, partition)
        if version is None or not exists(name):
            out[name] = StageStatus(name, "missing", ["never materialized" if version is None else "stored output missing"])
            continue
        now = current_inputs(instance, name, partition, configs[name])
        causes = []
        if recorded is None:
            causes.append("no provenance recorded")
        else:
            for p, v in now["parents"].items():
                if recorded["parents"].get(p) != v:
                    causes.append(f"{p} changed")
            for k, v in now["config"].items():
                if recorded["config"].get(k) != v:
                    causes.append(f"setting {k} changed ({recorded['config'].get(k)} -> {v})")
        out[name] = StageStatus(name, "stale" if causes else "fresh", causes)
    return out


def to_run(statuses: dict[str, StageStatus], stages: tuple[str, ...] = STAGES) -> list[str]:
    """Stages to execute: stale or missing ones and everything downstream, in graph order.

    Downstream stages whose inputs turn out identical skip their work inside the run
    (see assets.stage), so this over-selection never recomputes anything needlessly.
    """
    direct = {n for n, s in statuses.items() if s.state != "fresh"}
    chosen = direct | descendants(direct, stages)
    return [n for n in stages if n in chosen]
