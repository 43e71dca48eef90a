"""Everything the editor server holds for the one shot it edits: paths, store, reruns, caches."""
from __future__ import annotations

import threading
from pathlib import Path

from assets.codeversion import ROOT
from assets.home import ensure_home, home
from assets.runs import register, store
from ops.settings import Settings
from ops.shotio.load import read_shot_json

from .layers import Predictions
from .maskfiles import Staging
from .repose import Reposers
from .rerun import Reruns
from .results import Results


class EditorState:
    """One edited shot. Its working files live in INBETWEEN_HOME/editor/<partition>/ (rerun status, logs, output)."""

    def __init__(self, shot_dir: str | Path, settings: Settings | None = None, rerun_command: list[str] | None = None):
        read_shot_json(shot_dir)  # a missing or unparsable shot.json stops the editor with the CLI's one-line error
        ensure_home()
        self.shot_dir = Path(shot_dir).resolve()
        self.settings = settings or Settings()
        self.partition = register(self.shot_dir)
        self.store = store()
        self.workdir = home() / "editor" / self.partition
        self.scratch = self.workdir / "scratch"
        self.staging = Staging()
        self.save_lock = threading.Lock()
        self.reruns = Reruns(self.shot_dir, self.partition, self.workdir, home(), ROOT, rerun_command)
        self.reposers = Reposers(self.store, self.partition, self.settings.mu, self.settings.grad_tol)
        self.predictions = Predictions(self.store, self.partition)
        self.results = Results(self.store, self.partition)

    def start(self) -> None:
        self.reruns.start()

    def stop(self) -> None:
        self.reruns.stop()
