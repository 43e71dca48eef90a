"""Worker processes for the stages' heavy op calls, so that both keyframe lanes truly compute at once.

The deformer's L-BFGS loop, the cut search and the renderer are small-array NumPy and Python: on the
work-ahead's threads (assets/ahead.py) they took turns on the GIL with each other and with Dagster's
bookkeeping in the main thread (a cold run of arm_cross: key0's deformed frames 2.5 s alone, 8.3 s beside
the rest). A stage's compute function hands its one op call to `StageEnv.offload`, which runs it here, in one
of WORKERS processes, when the run has a pool, and in the calling thread otherwise.

The processes are forked from multiprocessing's fork server, a fresh interpreter that imports the ops once
(PRELOAD, about 1 s, while the run starts Dagster), never from this multi-threaded process (a fork of it
could inherit a lock some other thread holds). Each op's arguments and result are pickled between this
process and its own children: the one place besides `batch` where pickle crosses a process boundary, and
both ends are our code (docs/design.md, threat model). A pickle larger than SPILL_BYTES (the drawings, the
lanes' frames: 5-24 MB at 384 px) travels as a file in memory (tmpfs), written and read in one call each,
not through the pool's pipe: that pipe carries 64 KB at a time, and each of its hundreds of reads in this
process waited for the GIL behind Dagster's bookkeeping (a lane's 24 MB frames took 0.35-0.5 s to arrive, the
op itself 0.5 s). The files live in this process's own folder, removed at exit (and by the next pool when
the process that made it was killed). A worker ignores SIGINT (Ctrl-C reaches the whole
process group; the run itself stops and exits 130) and ends when this process does: the pool's processes are
terminated at exit, and one whose parent is gone finds its pipe closed.
"""
from __future__ import annotations

import atexit
import multiprocessing
import multiprocessing.util  # noqa: F401  (registers its exit handler before ours: see shutdown)
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
import types
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.reduction import ForkingPickler
from pathlib import Path
from typing import Any

from ops.cputime import charge

from . import warning_log

WORKERS = 2  # the machine's cores: the two lanes
# what the stages offload needs, imported once in the fork server (and never Dagster or torch)
PRELOAD = ("ops.appearance.lane", "ops.geometry.topology", "ops.segmentation.masks")
STARTUP_WAIT_S = 30.0  # at exit, how long the workers still being started are waited for
MANAGER_WAIT_S = 2.0  # at exit, how long the pool's manager thread is given to clean up after its killed workers
ENV_SWITCH = "INBETWEEN_PROCESSES"  # "0": every op in the calling thread (a batch worker's shot, a debugger)
SPILL_BYTES = 1 << 20  # a pickled argument list or result larger than this travels as a file, not through the pipe
SPILL_PREFIX = "inbetween-spill-"  # + this process's pid + "-": the folder of its files

_lock = threading.Lock()
_pool: ProcessPoolExecutor | None = None
_started = threading.Event()  # set once the current pool's workers are started
_spill_dir: Path | None = None  # this process's folder of spilled pickles, made on first use


def enabled() -> bool:
    """Whether runs in this process offload their op calls to worker processes."""
    return os.environ.get(ENV_SWITCH, "1") != "0"


def _init_worker(warnings_file: Path | None) -> None:
    """A worker ignores Ctrl-C (the run stops it) and sends its Python warnings where its parent's go."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if warnings_file is not None:
        warning_log.route_warnings(warnings_file)


def _context() -> Any:
    """multiprocessing's fork-server context, its server set to import PRELOAD (one server per process)."""
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(PRELOAD))
    return ctx


def warm_up() -> None:
    """Start the fork server now, without a pool: its imports (about a second of CPU) overlap whatever this process
    does next (a run's plan, on one core), so the pool that a run with stages to compute starts afterwards forks its
    workers from a server that is ready. A command that computes nothing loses only that CPU: the server is no
    child this process waits for, and it exits by itself once this process has (its end of a pipe closes)."""
    if not enabled():
        return
    import multiprocessing.forkserver

    _context()
    with _lock, _main_module_hidden():  # the server would otherwise import this process's __main__ too
        multiprocessing.forkserver.ensure_running()


def pool() -> ProcessPoolExecutor | None:
    """This process's pool, started on first use (None when disabled). Its processes start on a thread of their
    own, right away: the fork server's imports (about a second) overlap whatever the caller does next, and an op
    submitted meanwhile waits for them (`run`)."""
    global _pool, _started
    if not enabled():
        return None
    with _lock:
        if _pool is None:
            _pool = ProcessPoolExecutor(WORKERS, mp_context=_context(), initializer=_init_worker,
                                        initargs=(warning_log.routed(),))
            _started = threading.Event()
            threading.Thread(target=_start_workers, args=(_pool, _started), name="inbetween-processes",
                             daemon=True).start()
        return _pool


def _start_workers(executor: ProcessPoolExecutor, started: threading.Event) -> None:
    """Start every worker of the pool now, not at the first op (each submit starts one)."""
    try:
        with _main_module_hidden():
            for _ in range(WORKERS):
                executor.submit(int)
    except Exception:  # noqa: BLE001  (a broken pool is reported by the first op that uses it)
        pass
    finally:
        started.set()


def wait_started() -> None:
    """Block until this process's pool (if started) has started its workers: their fork server's imports done."""
    if _pool is not None:
        _started.wait()


@contextmanager
def _main_module_hidden() -> Iterator[None]:
    """While workers start: multiprocessing would have each run this process's __main__ again (as __mp_main__:
    the `inbetween` script imports the CLI, a script without a main guard runs itself); the ops need none of it."""
    main = sys.modules["__main__"]
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        sys.modules["__main__"] = main


def run(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """fn(*args, **kwargs) in a worker process of this process's pool (in this thread when there is none).

    fn must be importable by name outside Dagster (an ops function). A worker that dies (a crash in native code)
    is a RuntimeError naming fn, and the next call starts a new pool."""
    executor = pool()
    if executor is None:
        return fn(*args, **kwargs)
    _started.wait()  # the workers were started with this process's __main__ hidden: never by an op's submit
    folder = _spill_folder()
    try:
        packed, cpu = executor.submit(_call, fn, _pack((args, kwargs), folder), folder).result()
    except BrokenProcessPool:
        _discard(executor)
        raise RuntimeError(f"the worker process running {fn.__module__}.{fn.__qualname__} died "
                           "(a crash in native code); rerun the shot, or set INBETWEEN_PROCESSES=0 to run it "
                           "in this process") from None
    charge(cpu)  # the worker's CPU is this thread's stage's cost (report.json's cpu_seconds)
    return _unpack(packed)


def _call(fn: Callable[..., Any], packed: bytes | _Spilled, folder: Path) -> tuple[bytes | _Spilled, float]:
    """In the worker: fn(*args, **kwargs) of the packed (args, kwargs) -> (its result packed, the CPU seconds of
    this process it took, unpacking and packing included); an exception that could not be rebuilt from its
    pickle in this process (a constructor whose arguments are not its args) is sent as a RuntimeError with its
    type and message: failing to unpickle it would break the whole pool."""
    start = time.process_time()
    args, kwargs = _unpack(packed)
    try:
        out = _pack(fn(*args, **kwargs), folder)
        return out, time.process_time() - start
    except Exception as e:
        try:  # rebuilt from its reduction, as unpickling in this process would rebuild it
            rebuild, rebuild_args, *_ = e.__reduce__()
            rebuild(*rebuild_args)
        except Exception:  # noqa: BLE001  (whatever the exception's own constructor raises)
            raise RuntimeError(f"{type(e).__name__}: {e}") from None
        raise


@dataclass(frozen=True)
class _Spilled:
    """A pickle too large for the pipe: the file holding it (read once, then removed)."""

    path: str


def _pack(value: Any, folder: Path) -> bytes | _Spilled:
    """value pickled as the pool pickles its calls (ForkingPickler): the bytes, or the file they were written to
    when larger than SPILL_BYTES (in `folder`, made by mkdtemp: only this user can write there)."""
    data = ForkingPickler.dumps(value)  # a view of the pickler's buffer: copied only when it is sent inline
    if len(data) <= SPILL_BYTES:
        return bytes(data)
    fd, path = tempfile.mkstemp(dir=folder, suffix=".pickle")
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    return _Spilled(path)


def _unpack(packed: bytes | _Spilled) -> Any:
    """The value `_pack` packed; a spilled file is removed once read."""
    if isinstance(packed, _Spilled):
        path = Path(packed.path)
        data = path.read_bytes()
        path.unlink()
        return ForkingPickler.loads(data)
    return ForkingPickler.loads(packed)


def _spill_folder() -> Path:
    """This process's folder of spilled pickles: in memory (/dev/shm) where there is one, made on first use. The
    folders of processes that are gone (killed before their exit handler ran) are removed first."""
    global _spill_dir
    with _lock:
        if _spill_dir is None or not _spill_dir.is_dir():
            shm = Path("/dev/shm")
            base = shm if shm.is_dir() and os.access(shm, os.W_OK) else Path(tempfile.gettempdir())
            remove_orphans(base, SPILL_PREFIX)
            _spill_dir = Path(tempfile.mkdtemp(prefix=f"{SPILL_PREFIX}{os.getpid()}-", dir=base))
        return _spill_dir


def remove_orphans(base: Path, prefix: str) -> None:
    """Remove the folders `base`/`prefix`<pid>-* of processes that are gone (killed before they removed their own)."""
    for old in base.glob(f"{prefix}*"):
        if not _pid_alive(old.name[len(prefix):].split("-")[0]):
            shutil.rmtree(old, ignore_errors=True)


def _pid_alive(pid: str) -> bool:
    """Whether the process `pid` (a folder name's digits) still runs; an unreadable name counts as alive."""
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except (ValueError, PermissionError):  # not a pid; another user's process
        return True
    return True


def _discard(executor: ProcessPoolExecutor) -> None:
    global _pool
    with _lock:
        if _pool is executor:
            _pool = None
    executor.shutdown(wait=False, cancel_futures=True)


@atexit.register
def shutdown() -> None:
    """Terminate the pool's processes now (an op still computing is dropped with its run).

    A worker must not outlive this: multiprocessing's own exit handler joins every child process, and the pool's
    workers wait for work until told to stop, which a command leaving without finalizing the interpreter
    (assets/run/leave.py) never does, so that join would wait forever. Hence this runs before that handler (exit
    handlers run last registered first, and multiprocessing.util, imported above, registers its handler before
    this module registers this one), and it first lets the thread that starts the workers finish (a quick run
    can end while a worker is still being forked: left out of the kill below, it hung the exit). Then this
    process's spilled pickles are removed."""
    global _pool, _spill_dir
    with _lock:
        executor, _pool = _pool, None
        started = _started
        folder, _spill_dir = _spill_dir, None
    if executor is not None:
        started.wait(STARTUP_WAIT_S)
        manager = getattr(executor, "_executor_manager_thread", None)  # shutdown() forgets it
        for p in list(getattr(executor, "_processes", {}).values()):  # what shutdown(wait=False) leaves running
            p.kill()  # not terminate(): under nohup or a scheduler that ignores SIGTERM the workers inherit SIG_IGN
        executor.shutdown(wait=False, cancel_futures=True)
        if manager is not None:  # it sees the killed workers and closes the pool's pipes: let it finish before
            manager.join(MANAGER_WAIT_S)  # the exit handlers after this one run, or it closed a pipe they had
            #                               closed already and printed the error ("Bad file descriptor") at exit
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)
