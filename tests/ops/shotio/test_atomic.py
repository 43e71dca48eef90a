"""Files we write atomically get the mode a user expects, not mkstemp's owner-only 0600."""
from __future__ import annotations

import os
import stat

import numpy as np

from editor.shotfile import write_atomic
from ops.motion.shot_v2 import write_json
from ops.shotio.image_io import write_image


def mode(p) -> int:
    return stat.S_IMODE(os.stat(p).st_mode)


def test_a_new_file_is_readable_by_all_under_the_umask_and_a_replaced_one_keeps_its_mode(tmp_path):
    old = os.umask(0o022)
    try:
        frame = write_image(tmp_path / "0000.png", np.zeros((4, 4, 4), np.float32))
        assert mode(frame) == 0o644  # what open() gives: a compositor on another account can read the frame
        os.umask(0o027)
        assert mode(write_json(tmp_path / "shot.json", {"a": 1})) == 0o640
        os.chmod(tmp_path / "shot.json", 0o664)  # a shared shot, group-writable: the editor's save keeps that
        write_atomic(tmp_path / "shot.json", b"{}\n")
        assert mode(tmp_path / "shot.json") == 0o664 and (tmp_path / "shot.json").read_bytes() == b"{}\n"
        assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary left behind
    finally:
        os.umask(old)
