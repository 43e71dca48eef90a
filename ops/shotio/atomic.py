"""Putting a finished temporary file in place: the mode a user expects, then an atomic rename.

tempfile.mkstemp creates its file readable by its owner only (0600); renamed into place as it is, every frame,
preview and shot.json we write would be unreadable to the rest of a studio (a compositor, a farm account).
"""
from __future__ import annotations

import os
from pathlib import Path


def _umask() -> int:
    """The process's umask. Read from /proc where Linux shows it: setting it and putting it back (the portable
    way) would briefly change it for the run's other threads, which write files too."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def replace_into(tmp: str | Path, path: str | Path) -> None:
    """Rename tmp onto path, tmp's mode first made that of the file it replaces, or for a new file 0666 less the
    umask (what open() would have given it)."""
    try:
        mode = os.stat(path).st_mode & 0o7777
    except FileNotFoundError:
        mode = 0o666 & ~_umask()
    os.chmod(tmp, mode)
    os.replace(tmp, path)
