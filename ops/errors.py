"""The single exception type for bad input, and the warning list stages carry."""
from __future__ import annotations

from pathlib import Path


class ShotError(ValueError):
    """Bad input: the message names the file, the field and the fix, in one line."""

    def __init__(self, file: str | Path, field: str, problem: str, fix: str):
        self.file, self.field, self.problem, self.fix = str(file), field, problem, fix
        super().__init__(f"{file}: {field}: {problem}; fix: {fix}")
