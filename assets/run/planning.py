"""Planning without Dagster: the status of every stage of a shot (fresh, stale with causes, or missing), decided
from the shot files and the store alone (assets/provenance.py), and what the Dagster instance already records.

Freshness is ours, not Dagster's: deciding it from the store takes a few milliseconds and needs neither
Dagster nor torch, so an unchanged rerun ends in a fraction of a second (docs/design.md, "Two engines").
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ops.settings import Settings
from ops.shotio.load import load_shot
from ops.shotio.versions import source_versions
from ops.types import Shot
from resources.registry import register_shot
from resources.store import Store

from ..codeversion import ROOT, project_fingerprint
from ..graph import EVAL_STAGES, ShotGraph, shot_graph
from ..home import home, instance_id
from ..provenance import StageStatus, resolve, to_run
from ..resource_config import resource_config, resource_overrides
from .logs import quiet_dagster_warnings

# One thread of a process computes the facts at a time: the editor's server plans from several threads, and
# two of them importing the definitions at once see a half-initialized module (and share the temp file name).
_FACTS_LOCK = threading.Lock()


def code_records() -> dict[str, dict[str, str]]:
    """Code record of every stage. Cached in INBETWEEN_HOME keyed by a hash of the project's sources, so the
    planner needs Dagster (to import the stage definitions) only after the code changed."""
    return _definition_facts()["records"]


def resource_defaults() -> dict[str, dict]:
    """{resource key: {field: default}} of the resources stages declare (cached with the code records: the
    defaults are code)."""
    return _definition_facts()["resources"]


def _definition_facts() -> dict:
    """{"records": code records, "resources": resource defaults}, from the cache or the definitions.

    A process that imported the definitions before the sources changed on disk (a long-lived server)
    holds the old functions: it asks a fresh interpreter for the facts of the code as it is now.
    """
    with _FACTS_LOCK:
        return _definition_facts_locked()


def _definition_facts_locked() -> dict:
    cache = home() / "code_records.json"
    fingerprint = project_fingerprint()
    try:
        data = json.loads(cache.read_text())
        if data.get("fingerprint") == fingerprint and "resources" in data:
            return data
    except (OSError, ValueError):
        pass
    loaded = sys.modules.get("assets.definitions")
    if loaded is not None and loaded.LOADED_FINGERPRINT != fingerprint:
        out = subprocess.run([sys.executable, "-c", "import json; from assets.run.planning import _import_facts; "
                              "print(json.dumps(_import_facts()))"],
                             capture_output=True, text=True, check=True, cwd=ROOT)
        facts = json.loads(out.stdout.strip().splitlines()[-1])
    else:
        facts = _import_facts()
    data = {"fingerprint": fingerprint, **facts}
    cache.parent.mkdir(parents=True, exist_ok=True)
    tmp = cache.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(json.dumps(data))
    os.replace(tmp, cache)
    return data


def _import_facts() -> dict:
    quiet_dagster_warnings()
    from ..resource_types import RESOURCE_TYPES  # the resources' classes (Dagster's): their defaults are code

    return {"records": _import_code_records(), "resources": {k: resource_config(t()) for k, t in RESOURCE_TYPES.items()}}


def _import_code_records() -> dict[str, dict[str, str]]:
    from .. import stages  # noqa: F401  (declaring the stages fills STAGE_SPECS; no Dagster needed)
    from ..compute import STAGE_SPECS

    return {name: spec.code for name, spec in STAGE_SPECS.items()}


def current_resources() -> dict[str, dict]:
    """The configuration each resource of a run made now would have: its defaults and INBETWEEN_* overrides."""
    over = resource_overrides()
    return {k: {**v, **over.get(k, {})} for k, v in resource_defaults().items()}


class _OnFirstUse(Mapping):
    """A read-only mapping that `make()` computes when it is first read."""

    def __init__(self, make: Callable[[], dict]):
        self._make, self._value = make, None

    def _data(self) -> dict:
        if self._value is None:
            self._value = self._make()
        return self._value

    def __getitem__(self, key):
        return self._data()[key]

    def __iter__(self):
        return iter(self._data())

    def __len__(self) -> int:
        return len(self._data())


@dataclass
class Plan:
    """What a run of one shot would do."""

    shot: Shot
    partition: str
    sources: dict[str, str]  # source asset -> data version (content hash)
    statuses: dict[str, StageStatus]  # stage -> status
    recorded: bool  # the Dagster instance already records exactly these versions (the UI is current)
    observed: dict[str, str] = field(default_factory=dict)  # source -> the version the instance last observed

    @property
    def unobserved(self) -> dict[str, str]:
        """The sources whose current version the Dagster instance has not observed yet (a run reports these)."""
        return {k: v for k, v in self.sources.items() if self.observed.get(k) != v}

    @property
    def graph(self) -> ShotGraph:
        return shot_graph(self.shot.n_keys)

    @property
    def to_run(self) -> list[str]:
        return to_run(self.statuses)


def store() -> Store:
    return Store(home() / "storage")


def register(shot_dir: str | Path) -> str:
    """Partition key of a shot directory (registered on first use)."""
    return register_shot(home() / "shots.json", shot_dir)


def _ui_record_path(partition: str) -> Path:
    return store().root / partition / "dagster.json"


def plan(shot_dir: str | Path, settings: Settings | None = None, stages: tuple[str, ...] | None = None,
         shot: Shot | None = None) -> Plan:
    """Validate the shot and decide the status of each of `stages` (default: the shot's, the evaluation group
    left out; "evaluation": that group's) (ShotError on bad input)."""
    shot = shot or load_shot(shot_dir)
    graph = shot_graph(shot.n_keys)
    stages = graph.stages if stages is None else EVAL_STAGES if stages == "evaluation" else stages
    partition = register(shot.root)
    sources = source_versions(shot)
    st = store()
    # the code records and the resources' defaults matter only to a stage with a stored output: a shot's first
    # run in a new home decides without them, and so without importing Dagster before its first stage starts
    statuses = resolve(partition, st, sources, settings or Settings(), _OnFirstUse(code_records), stages, graph,
                       _OnFirstUse(current_resources))
    try:
        ui = json.loads(_ui_record_path(partition).read_text())
    except (OSError, ValueError):
        ui = {}
    current = {"instance": instance_id(), "sources": sources,
               "stages": {n: st.hash(n, partition) for n in stages}}
    same_instance = current["instance"] is not None and ui.get("instance") == current["instance"]
    recorded = (same_instance and ui.get("sources") == sources
                and all(ui.get("stages", {}).get(n) == v for n, v in current["stages"].items()))
    return Plan(shot, partition, sources, statuses, recorded, dict(ui.get("sources") or {}) if same_instance else {})


def _remember_ui(p: Plan, stages: tuple[str, ...]) -> None:
    """Note what the Dagster instance now records for this partition (so an unchanged rerun needs no Dagster)."""
    st = store()
    path = _ui_record_path(p.partition)
    try:
        ui = json.loads(path.read_text())
    except (OSError, ValueError):
        ui = {}
    if ui.get("instance") != instance_id():
        ui = {}
    ui.update({"instance": instance_id(), "sources": p.sources})
    ui.setdefault("stages", {}).update({n: st.hash(n, p.partition) for n in stages})
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(json.dumps(ui))
    os.replace(tmp, path)


def stage_warnings(partition: str, names: tuple[str, ...]) -> dict[str, int]:
    """How many input repairs (warnings) each stored stage recorded: {stage: count}, stages without any left out."""
    st = store()
    out = {}
    for name in names:
        _, recorded = st.provenance(name, partition)
        n = len((recorded or {}).get("warnings") or [])
        if n:
            out[name] = n
    return out


def status(shot_dir: str | Path, settings: Settings | None = None) -> Plan:
    """The plan of a shot: which stages the next run executes, and why."""
    return plan(shot_dir, settings)
