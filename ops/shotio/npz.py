"""Reading .npz files while other threads run: the stage outputs and the networks' weights.

numpy parses every array's header with ast.literal_eval, and CPython 3.11 keeps the AST constructor's recursion
depth in state that all threads share: two threads building ASTs at once (another .npz read, or a traceback being
formatted, which parses the failing line) can make one of them fail with "SystemError: AST constructor recursion
depth mismatch" (python/cpython#106905). The two lanes of a shot run side by side in threads, and a stage failed
so once in five runs of the suite. Every .npz the pipeline reads goes through read_npz: one lock keeps its own
reads from racing, and a read that another thread's parsing broke is read again (the shared depth is back in
balance once both parses end).
"""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

_PARSING = threading.Lock()
RETRIES = 3  # reads of one file after a race with another thread's parsing, before the error is raised
_RACE = "AST constructor recursion depth mismatch"


def read_npz(path: str | Path) -> dict[str, np.ndarray]:
    """{name: array} of every array in the .npz at path (no pickle), read under the module's lock."""
    for _ in range(RETRIES):
        try:
            return _read(path)
        except SystemError as e:
            if _RACE not in str(e):
                raise
    return _read(path)  # the last try's error is the caller's


def _read(path: str | Path) -> dict[str, np.ndarray]:
    with _PARSING, np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}
