"""The output frames written ahead (assets/run/staging.py): staged in a worker process once the frames are known,
handed over for their version only, and no staging folder outlives its run."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np

from assets.run.staging import PREFIX, StagedOutputs


def _frames(T=3, H=24, W=32):
    out = np.zeros((T, H, W, 4), np.float32)
    for i in range(T):
        out[i, 4:12, 2 + 4 * i:10 + 4 * i] = [0.2, 0.4, 0.6, 1.0]
    return out


def _staging(out):
    return sorted(p.name for p in out.glob(f"{PREFIX}*"))


def test_frames_are_staged_for_their_version_and_the_folders_removed(tmp_path):
    out = tmp_path / "out"
    staged = StagedOutputs(out, ("gif", "oca"), 12.0)
    staged.on_computed("seg0/frames", "v0", SimpleNamespace(frames=_frames()))  # not the shot's output: ignored
    assert not out.exists()
    staged.on_computed("inbetween_frames", "v1", SimpleNamespace(frames=_frames()))
    staged.on_computed("inbetween_frames", "v1", SimpleNamespace(frames=_frames()))  # a retried execution
    folder = staged.folder("v1")
    assert folder is not None and folder.parent == out and folder.name.startswith(f"{PREFIX}{os.getpid()}-")
    assert sorted(p.name for p in (folder / "frames").iterdir()) == ["0000.png", "0001.png", "0002.png"]
    assert (folder / "preview.gif").is_file() and not (folder / "oca").exists()
    assert staged.folder("v2") is None  # other frames (a shot saved meanwhile): written by write_outputs
    assert len(_staging(out)) == 1
    staged.discard()
    assert _staging(out) == []


def test_frames_already_in_out_dir_are_not_staged(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.json").write_text(json.dumps({"frames_version": "v1"}))
    staged = StagedOutputs(out, ("gif",), 12.0)
    staged.on_computed("inbetween_frames", "v1", SimpleNamespace(frames=_frames()))
    assert staged.folder("v1") is None and _staging(out) == []


def test_the_staging_folders_of_a_killed_process_are_removed_by_the_next(tmp_path):
    out = tmp_path / "out"
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    (out / f"{PREFIX}{gone.stdout.strip()}-abc" / "frames").mkdir(parents=True)
    (out / f"{PREFIX}{os.getpid()}-mine").mkdir()  # a live process's (this one's): kept
    staged = StagedOutputs(out, ("gif",), 12.0)
    staged.on_computed("inbetween_frames", "v1", SimpleNamespace(frames=_frames()))
    assert staged.folder("v1") is not None
    assert f"{PREFIX}{gone.stdout.strip()}-abc" not in _staging(out) and f"{PREFIX}{os.getpid()}-mine" in _staging(out)
    staged.discard()


def test_an_out_dir_that_cannot_be_made_stages_nothing(tmp_path):
    (tmp_path / "file").write_text("not a folder")
    staged = StagedOutputs(tmp_path / "file" / "out", ("gif",), 12.0)
    staged.on_computed("inbetween_frames", "v1", SimpleNamespace(frames=_frames()))  # no exception: nothing staged
    assert staged.folder("v1") is None
