"""`inbetween junctions`: T-junction proposals for the keys of a shot that have no clicks, and accepting them.

Real batches arrive without clicks. The proposals are read from the ink (ops/segmentation/junction_proposals.py)
and the key's predicted masks (the stored `key{k}/masks`, computed first when not fresh). They are never used
unless accepted: `--write` adds the ones scoring at least `min_score` to shot.json's `t_junctions` of the keys
that have none (a click always wins: a key with clicks keeps exactly its clicks), keeping the previous file as
shot.json.bak. The editor shows the same proposals, to accept one by one (`key_proposals`: one key, clicked
or not, without running the pipeline; the editor leaves out those a click is near).
"""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from ops.segmentation.junction_proposals import JunctionProposals, propose_t_junctions
from ops.settings import Settings
from ops.shotio.image_io import read_image, to_rgba
from ops.shotio.load import load_shot, read_shot_json
from ops.shotio.versions import source_versions
from ops.types import Masks, Shot

from ..geometry import key_masks
from .execute import execute
from .locks import shot_lock
from .planning import plan, register, store


def propose_junctions(shot_dir: str | Path, settings: Settings | None = None) -> dict[int, JunctionProposals]:
    """{key: proposals} for every key without T-junction clicks (its masks stage run first if not fresh)."""
    settings = settings or Settings()
    shot = load_shot(shot_dir)
    keys = [k for k in range(shot.n_keys) if not len(shot.t_junctions[k])]
    partition = register(shot.root)
    with shot_lock(partition):
        p = plan(shot.root, settings, tuple(f"key{k}/masks" for k in keys), shot=shot)
        if p.to_run:
            execute(p, settings, p.to_run)
    return {k: propose_t_junctions(store().read(f"key{k}/masks", partition), shot.key_pose(k), shot.skeleton)
            for k in keys}


def proposal_version(shot: Shot, k: int, settings: Settings | None = None) -> tuple[str, str, str]:
    """What key k's proposals are computed from: its drawing's and pose's versions (the masks stage's sources)
    and the occlusion predictor. The clicks are not part of it: they only hide proposals near them."""
    sources = source_versions(shot)
    return sources[f"key{k}/drawing"], sources[f"key{k}/pose"], (settings or Settings()).occlusion


def _masks_of(shot: Shot, k: int, settings: Settings) -> Masks:
    """key{k}/masks: the stored output when the plan calls it fresh, else computed as its stage would (nothing
    stored, no run started: the editor asks while a rerun may hold the shot's lock)."""
    name = f"key{k}/masks"
    p = plan(shot.root, settings, (name,), shot=shot)
    if p.statuses[name].state == "fresh":
        return store().read(name, p.partition)
    return key_masks(shot, k, to_rgba(read_image(shot.keyframes[k], f"keyframes[{k}]")), settings.occlusion)


def key_proposals(shot: Shot, k: int, settings: Settings | None = None) -> JunctionProposals:
    """Key k's proposals from its ink and masks, whether or not it has clicks (ShotError for a bad shot)."""
    settings = settings or Settings()
    return propose_t_junctions(_masks_of(shot, k, settings), shot.key_pose(k), shot.skeleton)


def accept_junctions(shot_dir: str | Path, proposals: dict[int, JunctionProposals], min_score: float) -> int:
    """Write the proposals scoring >= min_score into shot.json for keys that still have no clicks; returns how
    many were written. Atomic (temp file + rename); the previous shot.json is kept as shot.json.bak."""
    file, data = read_shot_json(shot_dir)
    tj = data.get("t_junctions") or [[] for _ in data.get("keyframes", [])]
    written = 0
    for k, props in proposals.items():
        if tj[k]:  # clicked since the proposals were made: the clicks win
            continue
        keep = props.scores >= min_score
        tj[k] = [[round(float(x), 1), round(float(y), 1)] for x, y in props.points[keep]]
        written += int(keep.sum())
    data["t_junctions"] = tj
    shutil.copyfile(file, file.with_name("shot.json.bak"))
    tmp = file.with_name(f".shot.json.tmp{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    os.replace(tmp, file)
    return written
