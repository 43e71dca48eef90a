"""`batch`: every shot of a root, each in a fresh worker process, a worker that dies being one failed shot."""
from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import context as mp_context
from pathlib import Path

from ops.errors import ShotError
from ops.settings import Settings
from ops.shotio.frames import DEFAULT_EXPORTS
from ops.shotio.load import check_batch, load_shot

from ..home import ensure_home
from .errors import HomeDamaged, ShotFailure, StageFailed
from .execute import EXECUTORS, run_shot
from .leave import exit_without_teardown
from .logs import warnings_to_log
from .planning import register


def _batch_worker(shot_dir: str, out_dir: str, settings: Settings, verbose: bool = False, executor: str = "in_process",
                  exports: tuple[str, ...] = DEFAULT_EXPORTS, fps: float = 12.0
                  ) -> tuple[str, dict | None, ShotFailure | None]:
    from ops.blending.rife_onnx import limit_threads

    from .. import processes

    if not verbose:
        warnings_to_log()
    limit_threads(1)  # two shots share two cores
    os.environ[processes.ENV_SWITCH] = "0"  # and each shot's lanes compute on threads: no processes of its own
    name = Path(shot_dir).name
    try:
        return shot_dir, run_shot(shot_dir, out_dir, settings, verbose=verbose, executor=executor, exports=exports,
                                  fps=fps), None
    except ShotError as e:
        return shot_dir, None, ShotFailure(str(e), name, True)
    except (StageFailed, HomeDamaged) as e:
        return shot_dir, None, ShotFailure(str(e), name, False)
    except Exception as e:  # one line per failed shot; other shots go on
        cause = " ".join(f"{type(e).__name__}: {e}".split())[:300]
        return shot_dir, None, ShotFailure(f"{shot_dir}: {cause}", name, False)


class _LeavingProcess(mp_context.SpawnProcess):
    """A batch worker that, once its shot is run and its result sent (a synchronous pipe write), exits without
    finalizing its interpreter (exit_without_teardown: 0.5 s a shot); a worker that raised exits as usual."""

    def run(self) -> None:
        super().run()
        exit_without_teardown(0)


class _LeavingContext(mp_context.SpawnContext):
    Process = _LeavingProcess


def batch(root: str | Path, out_dir: str | Path, workers: int = 2, settings: Settings | None = None,
          verbose: bool = False, on_done: Callable[[str, dict | None, ShotFailure | None], None] | None = None,
          executor: str = "in_process", exports: tuple[str, ...] = DEFAULT_EXPORTS, fps: float = 12.0
          ) -> tuple[dict, list[str]]:
    """Every shot directory under root, `workers` at a time; returns (reports by shot name, errors).

    Each error is a ShotFailure (a str naming the shot's failure in one line). on_done(shot name, report,
    error) is called as each shot ends. A batch whose valid shots together exceed the output-pixel bound
    is refused before any shot runs (ShotError).

    executor "celery": each shot is one run of the farm job whose steps run on Celery workers; `workers` is
    then how many shots are in flight (each an orchestrating process that mostly waits).
    """
    if executor not in EXECUTORS:
        raise ValueError(f"executor must be one of {EXECUTORS}, got {executor!r}")

    settings = settings or Settings()
    ensure_home()
    shots = sorted(d for d in Path(root).iterdir() if (d / "shot.json").is_file())
    valid = []
    for d in shots:
        try:
            valid.append(load_shot(d))
        except ShotError:
            pass  # its worker reports it, and the other shots go on
    check_batch(root, valid)
    for d in shots:  # register up front, one writer at a time
        register(d)
    reports, errors = {}, []
    # one fresh process per shot: a worker that ran shot after shot kept every one's leftovers (allocator
    # arenas, caches), and its peak RSS grew with the batch (1.77 GB over the 12 samples, one shot 1.2 GB)
    with ProcessPoolExecutor(max_workers=max(1, workers), mp_context=_LeavingContext(),
                             max_tasks_per_child=1) as pool:
        futures = {pool.submit(_batch_worker, str(d), str(Path(out_dir) / d.name), settings, verbose,
                               executor, exports, fps): d
                   for d in shots}
        for f in as_completed(futures):
            try:
                shot_dir, report, error = f.result()
            except BrokenProcessPool:  # a worker died (killed, out of memory): its shot failed, not the batch
                d = futures[f]
                shot_dir, report = str(d), None
                error = ShotFailure(f"{d}: run: the worker process died (killed, or out of memory); fix: rerun the "
                                    "batch (stored stages are kept); if it dies again, run this shot alone with "
                                    "`inbetween run`", d.name, False)
            if error:
                errors.append(error)
            else:
                reports[Path(shot_dir).name] = report
            if on_done is not None:
                on_done(Path(shot_dir).name, report, error)
    return reports, errors
