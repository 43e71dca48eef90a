"""Freshness of every stage of a shot, decided from the store and the shot files alone (no Dagster import).

Each stage records, with its output (resources/store.py), its provenance: the
data versions of its parents, the settings it read, its code record
(assets/codeversion.py) and its resources' configuration (assets/resource_config.py). A stage is
- missing: never stored, or its stored output is damaged;
- stale: its record differs from now (a parent changed, a setting it read
  changed, a file of its code changed), or a stage upstream of it is stale or
  missing (it will run again after that one);
- fresh: otherwise.
Status is transitive, so the stages it calls not fresh are exactly those the
next run executes (a stage executed because of its upstream may still find
its inputs unchanged after all and keep its output: it then reports cached).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ops.settings import Settings
from resources.store import Store

from .codeversion import changed_files
from .graph import ShotGraph


@dataclass
class StageStatus:
    name: str
    state: str  # "fresh" | "stale" | "missing"
    causes: list[str] = field(default_factory=list)


def parent_versions(parents: tuple[str, ...], partition: str, store: Store, sources: dict[str, str]
                    ) -> dict[str, str | None]:
    """Current data version of each parent: a source's content hash, a stage's stored output hash (None if missing)."""
    return {p: sources[p] if p in sources else store.hash(p, partition) for p in parents}


def provenance(parents: dict[str, str | None], settings_read: dict, code: dict[str, str],
               resources: dict[str, dict] | None = None) -> dict:
    """The record a stage stores with its output: parents' data versions, the settings it read, its code
    record, and the configuration of each resource it used."""
    return {"parents": parents, "settings": settings_read, "code": code, "resources": resources or {}}


def differences(recorded: dict | None, parents: dict, settings: Settings, code: dict[str, str],
                resources: dict[str, dict] | None = None) -> list[str]:
    """Why a stored output no longer matches its inputs (empty: it does). resources: the configuration each
    resource would have now (a record from before resources were recorded names none)."""
    if not recorded:
        return ["no provenance recorded"]
    causes = [f"{p} changed" for p, v in parents.items() if recorded.get("parents", {}).get(p) != v]
    values = settings.as_dict()
    for key, old in recorded.get("settings", {}).items():
        if values.get(key, old) != old:
            causes.append(f"setting {key} changed ({old} -> {values.get(key)})")
    for key, old in (recorded.get("resources") or {}).items():
        now = (resources or {}).get(key, old)
        changed = sorted(f for f in set(old) | set(now) if old.get(f) != now.get(f))
        if changed:
            causes.append(f"resource {key} changed (" + ", ".join(f"{f} {old.get(f)} -> {now.get(f)}" for f in changed)
                          + ")")
    files = changed_files(recorded.get("code", {}), code)
    if files:
        causes.append("code changed: " + ", ".join("the stage's own functions" if f == "<functions>" else f
                                                   for f in files))
    return causes


def resolve(partition: str, store: Store, sources: dict[str, str], settings: Settings,
            code: dict[str, dict[str, str]], stages: tuple[str, ...], graph: ShotGraph,
            resources: dict[str, dict] | None = None) -> dict[str, StageStatus]:
    """Status of each of `stages` of the shot's graph (and of the stages upstream of them), in graph order."""
    out: dict[str, StageStatus] = {}
    for name in graph.all_stages:  # parents before children
        digest, recorded = store.provenance(name, partition)
        if digest is None:
            damaged = store.path(name, partition).exists()
            out[name] = StageStatus(name, "missing", ["stored output damaged" if damaged else "never materialized"])
            continue
        upstream = [p for p in graph.parents[name] if p in out and out[p].state != "fresh"]
        causes = [f"upstream {p} {out[p].state}" for p in upstream]
        parents = parent_versions(graph.parents[name], partition, store, sources)
        causes += [c for c in differences(recorded, parents, settings, code[name], resources)
                   if c.removesuffix(" changed") not in upstream]
        out[name] = StageStatus(name, "stale" if causes else "fresh", causes)
    return {n: out[n] for n in stages}


def to_run(statuses: dict[str, StageStatus]) -> list[str]:
    """The stages a run executes: every one that is not fresh, in graph order."""
    return [n for n, s in statuses.items() if s.state != "fresh"]
