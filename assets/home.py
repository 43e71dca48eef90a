"""Where the project keeps its state: INBETWEEN_HOME (default ./.inbetween). No Dagster import.

  dagster/      the DAGSTER_HOME (SQLite by default, telemetry off), unless the user set DAGSTER_HOME
  storage/      every stage's output, one folder per shot partition (resources/store.py)
  shots.json    which directory each partition key names (resources/registry.py)
  logs/         Dagster's event log of each CLI run, as text
  locks/        one lock file per shot partition: two runs of one shot take turns
"""
from __future__ import annotations

import os
import uuid
from pathlib import Path

DAGSTER_YAML = """\
# Written by inbetween: local SQLite storage, no telemetry. See docs/production.md for Postgres.
telemetry:
  enabled: false
# every run's events in one SQLite file ($DAGSTER_HOME/event_log.db) instead of a new file per run, whose
# tables and Alembic stamp cost each run about 0.6 s of CPU (docs/performance.md)
event_log_storage:
  module: dagster._core.storage.event_log
  class: ConsolidatedSqliteEventLogStorage
  config:
    base_dir:
      env: DAGSTER_HOME
"""
INSTANCE_ID_FILE = "inbetween_instance_id"


def home() -> Path:
    return Path(os.environ.get("INBETWEEN_HOME", Path.cwd() / ".inbetween")).resolve()


def dagster_home() -> Path:
    return Path(os.environ.get("DAGSTER_HOME", home() / "dagster")).resolve()


def shots_root() -> Path:
    return Path(os.environ.get("INBETWEEN_SHOTS", "data_samples")).resolve()


def ensure_home() -> Path:
    """Create the home and point DAGSTER_HOME at it unless the user set one; a deleted home starts over."""
    h = home()
    dh = Path(os.environ.setdefault("DAGSTER_HOME", str(h / "dagster")))
    dh.mkdir(parents=True, exist_ok=True)
    if not (dh / "dagster.yaml").exists():
        (dh / "dagster.yaml").write_text(DAGSTER_YAML)
    instance_id(create=True)
    return h


def instance_id(create: bool = False) -> str | None:
    """Identity of the Dagster instance under DAGSTER_HOME: a new home (or a deleted one) gets a new id."""
    path = dagster_home() / INSTANCE_ID_FILE
    try:
        return path.read_text().strip() or None
    except OSError:
        if not create:
            return None
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(uuid.uuid4().hex)
    try:
        os.link(tmp, path)  # atomic and exclusive: of two processes creating it at once, one id wins
    except FileExistsError:
        pass
    finally:
        tmp.unlink()
    return path.read_text().strip()
