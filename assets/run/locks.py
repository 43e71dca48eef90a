"""One run of a shot at a time, across processes."""
from __future__ import annotations

import fcntl
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from ..home import home


@contextmanager
def shot_lock(partition: str, on_wait: Callable[[], None] | None = None) -> Iterator[None]:
    """Exclusive lock of one shot partition across processes; calls on_wait() once if another run holds it."""
    path = home() / "locks" / f"{partition}.lock"
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if on_wait:
                on_wait()
            fcntl.flock(f, fcntl.LOCK_EX)
        yield
