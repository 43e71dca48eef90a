"""A checker of shot.json version 2 as docs/shot-format.md ("Version 2") writes it down, for the tests."""
from __future__ import annotations

import math
from pathlib import Path


def check_v2(data: dict, shot_dir: Path | None = None) -> None:
    """AssertionError naming the first field that breaks the v2 spec."""
    assert data["format"] == "inbetween-shot/2", "format"
    keys = data["keyframes"]
    assert isinstance(keys, list) and len(keys) >= 1 and all(isinstance(k, str) for k in keys), "keyframes"
    n = len(keys)
    kf = data.get("key_frames", [0] if n == 1 else None)
    assert isinstance(kf, list) and len(kf) == n, "key_frames: one per keyframe"
    assert all(isinstance(k, int) and not isinstance(k, bool) for k in kf), "key_frames: integers"
    assert kf[0] == 0 and all(b > a for a, b in zip(kf, kf[1:])), "key_frames: first 0, strictly increasing"
    sk = data["skeleton"]
    J = len(sk["joints"])
    assert len(set(sk["joints"])) == J and len(sk["parents"]) == J and sk["parents"].count(-1) == 1, "skeleton"
    poses = data["poses"]
    frames = [p["frame"] for p in poses]
    assert all(isinstance(f, (int, float)) and not isinstance(f, bool) and math.isfinite(f) for f in frames), "frame"
    assert all(b > a for a, b in zip(frames, frames[1:])), "poses: strictly increasing frame"
    assert all("t" not in p for p in poses), "poses: v2 has frame, not t"
    assert set(kf) <= set(frames), "poses: one pose at every key frame"
    if n >= 2:
        assert frames[-1] <= kf[-1], "poses: none after the last key frame (N >= 2)"
    for p in poses:
        assert len(p["joints"]) == J and all(len(j) == 3 and all(math.isfinite(v) for v in j) for j in p["joints"]), \
            "poses: [x, y, z] per joint"
    assert len(data["t_junctions"]) == n, "t_junctions: one entry per key"
    masks = data["masks"]
    assert len(masks["foreground"]) == n and len(masks["occlusion"]) == n, "masks: one entry per key"
    if shot_dir is not None:
        for k in keys + [m for m in masks["foreground"] if m]:
            assert (shot_dir / k).is_file(), f"file {k}"
