"""Content hashes of exactly what each source asset of a shot covers (its data versions)."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from ops.shotio.load import ground_truth_files
from ops.types import Shot


def _digest(*parts) -> str:
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, (bytes, bytearray)):
            h.update(part)
        else:
            h.update(json.dumps(part, sort_keys=True, default=str).encode())
        h.update(b"\x00")
    return h.hexdigest()[:24]


def _file_bytes(path: str | None) -> bytes:
    return Path(path).read_bytes() if path else b"<none>"


def source_versions(shot: Shot) -> dict[str, str]:
    """Content hash of exactly what each source asset covers.

    Keys: 'key{k}/drawing' (image + manual masks), 'key{k}/pose' (skeleton + that keyframe's pose),
    'key{k}/t_junctions', 'seg{s}/motion' (skeleton + the pose and clock of every frame of segment s; a v1
    shot's one segment is its whole motion), 'ground_truth' (reference frames).
    """
    sk = [list(shot.skeleton.joints), shot.skeleton.parents.tolist()]
    out = {}
    for k in range(shot.n_keys):
        out[f"key{k}/drawing"] = _digest(_file_bytes(shot.keyframes[k]), _file_bytes(shot.foreground_masks[k]),
                                         *[_file_bytes(p) for p in shot.occlusion_masks[k]])
        out[f"key{k}/pose"] = _digest(sk, shot.key_pose(k).round(6).tolist())
        out[f"key{k}/t_junctions"] = _digest(shot.t_junctions[k].round(6).tolist())
    for s in range(shot.n_segments):
        f = shot.segment_frames(s)
        out[f"seg{s}/motion"] = _digest(sk, shot.segment_times(s).round(9).tolist(), shot.poses[f].round(6).tolist())
    gt = ground_truth_files(shot.ground_truth) if shot.ground_truth else []
    out["ground_truth"] = _digest(*[x for p in gt for x in (p.name, p.read_bytes())]) if gt else _digest("<none>")
    return out
