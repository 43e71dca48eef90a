"""run_shot takes the frames it just computed from memory, never a value other than the stored one."""
import importlib

import numpy as np

from ops.types import OutputFrames
from resources.store import Store, content_hash

execute = importlib.import_module("assets.run.execute")  # the module (the package exports its function by that name)


def _frames(v: float) -> OutputFrames:
    return OutputFrames(np.linspace(0, 1, 3), np.array([0.0, 0.5, 1.0]), np.full((3, 4, 5, 4), v, np.float32),
                        "optimal")


def test_the_value_computed_here_is_used_only_while_it_is_the_stored_one(tmp_path, monkeypatch):
    st = Store(tmp_path)
    monkeypatch.setattr(execute, "store", lambda: st)
    stored, computed = _frames(0.25), _frames(0.75)
    st.write("inbetween_frames", "shot", stored, content_hash(stored))
    read = []
    monkeypatch.setattr(st, "read", lambda name, partition: read.append(name) or Store.read(st, name, partition))
    # computed here and stored: no read back
    same = execute.read_output("inbetween_frames", "shot", {"inbetween_frames": (content_hash(stored), stored)})
    assert same is stored and read == []
    # what this process computed is not what is stored (another process wrote since): the stored one
    other = execute.read_output("inbetween_frames", "shot", {"inbetween_frames": (content_hash(computed), computed)})
    np.testing.assert_array_equal(other.frames, stored.frames)
    # nothing computed here (a cached stage): read
    np.testing.assert_array_equal(execute.read_output("inbetween_frames", "shot", {}).frames, stored.frames)
    assert read == ["inbetween_frames", "inbetween_frames"]
