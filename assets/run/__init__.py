"""The run machinery beneath every front end: the CLI, `inbetween eval`, the editor and the farm call this.

One concern per module:
- errors.py    how a run fails, in one line (StageFailed, RunInterrupted, HomeDamaged, ShotFailure)
- planning.py  the status of every stage, from the shot files and the store alone (no Dagster, no torch)
- locks.py     one run of a shot at a time, across processes
- logs.py      Dagster's event log and Python warnings to files under INBETWEEN_HOME/logs
- session.py   the Dagster instance and Definitions, materializing stages, SQLite's lock retried
- execute.py   run_shot, evaluate_stages, export_masks: plan, run what is not fresh, settle, write
- batch.py     every shot of a root in worker processes
- leave.py     leaving a finished command without finalizing the interpreter

Front ends only parse, call and print.
"""
from .batch import batch
from .errors import HomeDamaged, RunInterrupted, ShotFailure, StageFailed
from .execute import EXECUTORS, evaluate_stages, execute, export_masks, run_shot
from .logs import warnings_to_log
from .planning import Plan, plan, register, stage_warnings, status, store

__all__ = ["EXECUTORS", "HomeDamaged", "Plan", "RunInterrupted", "ShotFailure", "StageFailed", "batch",
           "evaluate_stages", "execute", "export_masks", "plan", "register", "run_shot", "stage_warnings", "status",
           "store", "warnings_to_log"]
