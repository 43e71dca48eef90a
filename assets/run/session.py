"""The Dagster side of a run: the instance and the Definitions (built once per process), materializing the
selected stages of one partition in process or on the farm, and SQLite's "database is locked" retried."""
from __future__ import annotations

import fcntl
import functools
import os
import random
import time
from contextlib import contextmanager
from pathlib import Path

from ops.settings import Settings

from ..graph import ShotGraph
from ..home import ensure_home, home, instance_id
from .errors import HomeDamaged, raise_failure
from .logs import quiet_dagster_warnings


def _database_locked(e: BaseException | None) -> bool:
    """True when SQLite's "database is locked" is anywhere in the exception, its chain or its stage's trace."""
    seen = 0
    while e is not None and seen < 20:
        if "database is locked" in f"{e} {getattr(e, 'trace', '')}":
            return True
        e, seen = e.__cause__ or e.__context__, seen + 1
    return False


LOCKED_ATTEMPTS = 6


def retry_database_locked(fn):
    """Retry `fn` when another process holds the SQLite Dagster instance locked longer than SQLite waits.

    With backoff (about 0.5, 1, 2, 4, 8 s, jittered so two waiting processes do not collide again).
    Safe to repeat: stages stored by a failed attempt are fresh on the next one, and are not run again.
    """
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        for attempt in range(LOCKED_ATTEMPTS):
            try:
                return fn(*args, **kwargs)
            except Exception as e:
                if attempt == LOCKED_ATTEMPTS - 1 or not _database_locked(e):
                    raise
                time.sleep(min(8.0, 0.5 * 2**attempt) * (0.5 + random.random()))
        raise AssertionError("unreachable")

    return wrapper


class Session:
    """The Dagster instance and the Definitions, built once per process per (settings, home).

    The instance is opened on first use (`instance`): a run starts computing its stages (assets/ahead.py)
    while it opens, which on a new home creates its SQLite tables.
    """

    _cache: dict[tuple, Session] = {}

    def __init__(self, settings: Settings):
        ensure_home()
        quiet_dagster_warnings()
        import dagster as dg

        from ..definitions import build_resources

        self.dg = dg
        self.settings = settings
        self.resources = build_resources(settings)  # the stages' resources, as every Definitions here binds them
        self._jobs: dict[ShotGraph, object] = {}
        self._instance = None

    def job(self, graph: ShotGraph):
        """The asset job of a shot's graph (its stages, its evaluation group's and its sources), built once.

        A run builds only its own shot's assets: the UI's Definitions hold every stage of every shot size (172
        assets), which took a second of this process's main thread from the stages' cores (docs/performance.md).
        """
        if graph not in self._jobs:
            from ..definitions import shot_definitions

            defs = shot_definitions(graph.all_stages, graph.sources, self.settings)
            self._jobs[graph] = defs.resolve_implicit_global_asset_job_def()
        return self._jobs[graph]

    @property
    def instance(self):
        if self._instance is None:  # not kept when opening fails: the next call tries again
            self._instance = open_instance()
        return self._instance

    @classmethod
    def get(cls, settings: Settings) -> Session:
        ensure_home()
        # the instance id changes when the Dagster home was deleted: a cached instance would write into
        # SQLite files that no longer exist, so a long-lived process (the editor) opens the new home
        key = (settings, home(), os.environ.get("DAGSTER_HOME"), os.environ.get("INBETWEEN_SHOTS"), instance_id())
        if key not in cls._cache:
            cls._cache[key] = cls(settings)
        return cls._cache[key]

    def ensure_partition(self, partition: str) -> None:
        if not self.instance.has_dynamic_partition("shots", partition):
            self.instance.add_dynamic_partitions("shots", [partition])

    def observe(self, partition: str, sources: dict[str, str]) -> None:
        """Record the sources' data versions as observations (no run is launched)."""
        from ..stage import asset_key

        for name, version in sources.items():
            self.instance.report_runless_asset_event(self.dg.AssetObservation(
                asset_key=asset_key(name), partition=partition, tags={"dagster/data_version": version}))

    def materialize(self, shot: str, partition: str, graph: ShotGraph, names: list[str], log_path: Path,
                    verbose: bool = False):
        """Run the named stages of one partition (stages of `graph`) in one in-process execution; StageFailed if a
        stage raises."""
        from ..stage import asset_key

        run_config = {"loggers": {"file": {"config": {"path": str(log_path)}},
                                  "console": {"config": {"log_level": "DEBUG" if verbose else "CRITICAL"}}}}
        with partitions_known(self.instance):
            result = self.job(graph).execute_in_process(
                instance=self.instance, partition_key=partition, asset_selection=[asset_key(n) for n in names],
                run_config=run_config, raise_on_error=False, tags={"inbetween/shot": partition})
        if not result.success:
            raise_failure(result.all_events, shot, log_path)
        return result

    def materialize_farm(self, shot: str, partition: str, names: list[str], log_path: Path, verbose: bool = False):
        """Run the named stages of one partition as one run of the farm job: each step on a Celery worker
        (assets/farm/), this process orchestrating; StageFailed if a stage raises."""
        from ..definitions import farm_job, resources_config
        from ..stage import asset_key

        run_config = {"loggers": {"file": {"config": {"path": str(log_path)}},
                                  "console": {"config": {"log_level": "DEBUG" if verbose else "CRITICAL"}}},
                      "resources": resources_config(self.settings)}
        result = self.dg.execute_job(
            self.dg.reconstructable(farm_job), self.instance, run_config=run_config,
            tags={"inbetween/shot": partition, "dagster/partition": partition},
            asset_selection=[asset_key(n) for n in names])
        if not result.success:
            raise_failure(result.all_events, shot, log_path)
        return result


@contextmanager
def partitions_known(instance):
    """While open, the instance answers "does this dynamic partition exist?" from memory once it has said yes.

    Dagster asks it for every input of every step (a SQLite query on a new connection each time: a quarter of
    a step's recording); within one run the shot's partition, added before it started, stays."""
    ask = instance.has_dynamic_partition
    known: set[tuple[str, str]] = set()

    def has_dynamic_partition(partitions_def_name: str, partition_key: str) -> bool:
        if (partitions_def_name, partition_key) in known:
            return True
        found = ask(partitions_def_name, partition_key)
        if found:
            known.add((partitions_def_name, partition_key))
        return found

    instance.has_dynamic_partition = has_dynamic_partition
    try:
        yield instance
    finally:
        del instance.has_dynamic_partition  # the class's method again


def open_instance():
    """The Dagster instance of DAGSTER_HOME; HomeDamaged (one line, with the fix) when it cannot be opened."""
    import dagster as dg

    from ..home import dagster_home

    lock = home() / "locks" / "dagster-instance.lock"
    lock.parent.mkdir(parents=True, exist_ok=True)
    try:
        # one process at a time: two processes opening a new SQLite home both create its tables, and the
        # second fails with "table jobs already exists" (batch workers starting on a fresh home)
        with open(lock, "w") as f:
            fcntl.flock(f, fcntl.LOCK_EX)
            instance = dg.DagsterInstance.get()
            instance.get_runs_count()  # opens the run storage: a damaged SQLite file fails here, not mid-run
        return instance
    except Exception as e:
        if _database_locked(e):
            raise
        raise HomeDamaged(dagster_home(), e) from e
