"""The output frames written ahead, while Dagster records the run's last steps.

Once the shot's last stage has computed its frames, what is left of a run is Dagster recording the last steps
(0.5-1 s of this process's main thread) and writing the outputs (the PNG frames, the GIF: 0.4-0.7 s at 384 px,
which waited for the recording). `StagedOutputs` writes them as soon as the frames are known, in a worker process
(assets/processes.py: a core the recording does not use), into a hidden folder of OUT_DIR; when the run has
succeeded, `write_outputs(staged=...)` only renames them into place. A run that fails, or whose frames are not
the ones staged (a shot saved meanwhile), leaves OUT_DIR as it was, and its staging folders are removed.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import threading
from pathlib import Path
from typing import Any

from ops.shotio.frames import stage_outputs, written_version

from .. import processes

PREFIX = ".staging-"  # + this process's pid + "-": a staging folder in OUT_DIR
STAGE = "inbetween_frames"  # the stage whose output the outputs are


class StagedOutputs:
    """Outputs of OUT_DIR written ahead, per data version of the shot's frames."""

    def __init__(self, out_dir: str | Path, exports: tuple[str, ...], fps: float):
        self.out_dir, self.exports, self.fps = Path(out_dir), tuple(exports), float(fps)
        self._lock = threading.Lock()
        self._jobs: dict[str, tuple[Path, threading.Thread]] = {}  # data version -> (folder, its writer)
        self._done: set[str] = set()  # versions whose folder holds every staged file

    def on_computed(self, stage: str, version: str, value: Any) -> None:
        """A stage computed a new output (WorkAhead.on_computed): the frames' are staged on a thread of their own."""
        if stage != STAGE or written_version(self.out_dir) == version:  # write_outputs writes none of them
            return
        with self._lock:
            if version in self._jobs:  # the same frames again (a retried execution)
                return
            try:
                self.out_dir.mkdir(parents=True, exist_ok=True)
                processes.remove_orphans(self.out_dir, PREFIX)  # of killed runs
                folder = Path(tempfile.mkdtemp(dir=self.out_dir, prefix=f"{PREFIX}{os.getpid()}-"))
            except OSError:  # OUT_DIR not writable: write_outputs meets it too, and reports it
                return
            # not named inbetween-ahead-*: leaving the command waits for those (assets/run/leave.py)
            thread = threading.Thread(target=self._stage, args=(version, folder, value.frames), daemon=True,
                                      name="inbetween-staging")
            self._jobs[version] = (folder, thread)
        thread.start()

    def _stage(self, version: str, folder: Path, frames: Any) -> None:
        try:
            processes.run(stage_outputs, folder, frames, self.exports, self.fps)
        except Exception:  # noqa: BLE001  (a full disk, a dead worker: write_outputs writes them itself, and says)
            return
        with self._lock:
            self._done.add(version)

    def folder(self, version: str) -> Path | None:
        """The folder holding the outputs of the frames of `version`, once written (waited for); None if they
        were not staged or their writing failed."""
        with self._lock:
            job = self._jobs.get(version)
        if job is None:
            return None
        job[1].join()
        with self._lock:
            return job[0] if version in self._done else None

    def discard(self) -> None:
        """Remove every staging folder (waiting for their writers first: a writer still running would recreate
        files in a removed folder)."""
        with self._lock:
            jobs = list(self._jobs.values())
            self._jobs.clear()
            self._done.clear()
        for folder, thread in jobs:
            thread.join()
            shutil.rmtree(folder, ignore_errors=True)
