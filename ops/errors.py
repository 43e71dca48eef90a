"""The single exception type for bad input, and the warning list stages carry."""
from __future__ import annotations

from pathlib import Path


class ShotError(ValueError):
    """Bad input: the message names the file, the field and the fix, in one line."""

    def __init__(self, file: str | Path, field: str, problem: str, fix: str):
        self.file, self.field, self.problem, self.fix = str(file), field, problem, fix
        super().__init__(f"{file}: {field}: {problem}; fix: {fix}")

    def __reduce__(self):
        """Pickled by its four parts (a stage's op raises it in a worker process: assets/processes.py)."""
        return type(self), (self.file, self.field, self.problem, self.fix)
