"""Everything the editor server holds for the one shot it edits: paths, store, reruns, caches."""
from __future__ import annotations

import fcntl
import threading
from pathlib import Path

from assets.codeversion import ROOT
from assets.home import ensure_home, home
from assets.run import register, store
from assets.run.reruns import Reruns
from ops.errors import ShotError
from ops.settings import Settings
from ops.shotio.load import read_shot_json

from .jointcheck import Foregrounds
from .layers import Predictions
from .maskfiles import Staging
from .proposals import Proposals
from .repose import Reposers
from .results import Results


class EditorState:
    """One edited shot. Its working files live in INBETWEEN_HOME/editor/<partition>/ (rerun status, logs, output)."""

    def __init__(self, shot_dir: str | Path, settings: Settings | None = None, rerun_command: list[str] | None = None,
                 url: str = ""):
        read_shot_json(shot_dir)  # a missing or unparsable shot.json stops the editor with the CLI's one-line error
        ensure_home()
        self.shot_dir = Path(shot_dir).resolve()
        self.settings = settings or Settings()
        self.partition = register(self.shot_dir)
        self.store = store()
        self.workdir = home() / "editor" / self.partition
        self._lock_file = self._claim(url)
        self.scratch = self.workdir / "scratch"
        self.staging = Staging()
        self.save_lock = threading.Lock()
        self.reruns = Reruns(self.shot_dir, self.partition, self.workdir, home(), ROOT, rerun_command)
        self.reposers = Reposers(self.store, self.partition, self.settings.mu, self.settings.grad_tol)
        self.predictions = Predictions(self.store, self.partition, self.settings.occlusion)
        self.foregrounds = Foregrounds(self.store, self.partition)  # the save's joint check (editor/jointcheck.py)
        self.results = Results(self.store, self.partition)
        self.proposals = Proposals(self.settings)  # T-junction proposals per key (editor/proposals.py)

    def _claim(self, url: str):
        """One editor per shot: two would both rerun it and both keep its rerun status."""
        self.workdir.mkdir(parents=True, exist_ok=True)
        f = open(self.workdir / "editor.lock", "a+")
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.seek(0)
            other = f.read().strip() or "another process"
            f.close()
            raise ShotError(self.shot_dir, "editor", f"this shot is already open in an editor at {other}",
                            "use that one, or stop it first") from None
        f.seek(0)
        f.truncate()
        f.write(url)
        f.flush()
        return f

    def start(self) -> None:
        self.reruns.start()

    def stop(self) -> None:
        self.reruns.stop()
        self._lock_file.close()  # releases the claim
