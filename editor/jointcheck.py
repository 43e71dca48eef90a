"""The editor's own check of a save: a key pose's joint must lie on its keyframe's character.

The CLI repairs a joint off the drawing with a warning (the template snaps it); in the editor such a joint is
a drag gone astray, and saving it would start a full rerun for nothing. So a key pose's joint that was moved
(or added) since the saved shot is refused when it lies farther than FAR_PX from the character's foreground:
the stored `key{k}/masks` foreground when it was computed from this drawing (and its manual masks; the pose
it was computed with decides only which stray marks count, so any pose will do: the foreground the page
shows), else the manual foreground mask the shot names, else the foreground predicted for the new pose
(ops.segmentation.foreground, tens of milliseconds). Joints the saved shot already had where they are
are left to the CLI's warning. Every key pose's joints must also lie inside the image.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy import ndimage

from ops.errors import ShotError
from ops.segmentation.foreground import segment_foreground
from ops.segmentation.masks import NEAR_OUTSIDE_PX
from ops.shotio.image_io import read_image, to_rgba
from ops.shotio.versions import source_versions
from ops.types import Shot
from resources.store import Store

from .shotfile import key_pose_indices

FAR_PX = NEAR_OUTSIDE_PX  # a joint farther than this from the foreground is what the CLI calls "far outside"


def mask_inside(path: str | Path, field: str) -> np.ndarray:
    """(H, W) bool inside of a manual mask file, by the masks stage's rule: light, and opaque where it has alpha."""
    img = read_image(path, field)
    return img[..., 0] > 0.5 if img.shape[2] < 4 else (img[..., 0] > 0.5) & (img[..., 3] > 0.5)


class Foregrounds:
    """The character's (H, W) bool foreground per keyframe of a candidate shot, cached by what it is made of."""

    def __init__(self, store: Store, partition: str):
        self.store, self.partition = store, partition
        self._cache: dict[tuple, np.ndarray] = {}
        self._lock = threading.Lock()

    def of(self, shot: Shot, k: int) -> np.ndarray:
        """Keyframe k's foreground: the stored masks' when made from this drawing, else manual, else predicted."""
        sources = source_versions(shot)
        drawing = sources[f"key{k}/drawing"]
        name = f"key{k}/masks"
        digest, recorded = self.store.provenance(name, self.partition)
        if digest is not None and (recorded or {}).get("parents", {}).get(f"key{k}/drawing") == drawing:
            key, make = ("store", digest), lambda: self.store.read(name, self.partition).foreground
        elif shot.foreground_masks[k]:
            key, make = ("manual", drawing), lambda: mask_inside(shot.foreground_masks[k], f"masks.foreground[{k}]")
        else:
            def make():
                image = to_rgba(read_image(shot.keyframes[k], f"keyframes[{k}]"))
                return segment_foreground(image, shot.key_pose(k), shot.skeleton).mask

            key = ("predicted", drawing, sources[f"key{k}/pose"])
        with self._lock:
            if key in self._cache:
                return self._cache[key]
        fg = make()
        with self._lock:
            self._cache = {key: fg, **{c: v for c, v in list(self._cache.items())[-3:] if c != key}}
        return fg


def _moved(data: dict, before: dict | None, k: int, idx: int) -> list[int]:
    """Joints of key pose `idx` (keyframe k) that are new or elsewhere than in the saved shot (by joint name)."""
    names = data["skeleton"]["joints"]
    old: dict[str, list] = {}
    try:
        old_idx = key_pose_indices(before)[k]
        old = dict(zip(before["skeleton"]["joints"], before["poses"][old_idx]["joints"]))
    except (TypeError, KeyError, IndexError, ValueError):
        pass  # no saved skeleton or pose to compare with: every joint is new
    return [j for j, (name, p) in enumerate(zip(names, data["poses"][idx]["joints"]))
            if not isinstance(old.get(name), list) or [float(c) for c in old[name][:2]] != [float(c) for c in p[:2]]]


def check_key_joints(shot: Shot, data: dict, file: Path, before: dict | None,
                     foreground: Callable[[Shot, int], np.ndarray]) -> None:
    """ShotError naming the first key-pose joint outside the image, or moved onto blank paper (FAR_PX away from
    foreground(shot, k), an (H, W) bool). `data` is the candidate shot.json object `shot` was loaded from,
    `before` the saved one (None: none)."""
    h, w = shot.size
    joints = shot.skeleton.joints
    for k, idx in enumerate(key_pose_indices(data)):
        pose = np.asarray(data["poses"][idx]["joints"], np.float64)
        for j, (x, y, _) in enumerate(pose):
            if not (-0.5 <= x <= w - 0.5 and -0.5 <= y <= h - 0.5):
                raise ShotError(file, f"poses[{idx}].joints[{j}]",
                                f"joint {joints[j]!r} at ({x:.1f}, {y:.1f}) lies outside the {w}x{h} keyframe {k}",
                                "drag it back onto the drawing")
        moved = _moved(data, before, k, idx)
        if not moved:
            continue
        away = ndimage.distance_transform_edt(~foreground(shot, k))
        for j in moved:
            x, y = pose[j, :2]
            d = float(away[int(round(y)), int(round(x))])
            if d > FAR_PX:
                raise ShotError(file, f"poses[{idx}].joints[{j}]",
                                f"joint {joints[j]!r} at ({x:.1f}, {y:.1f}) lies on blank paper, {d:.0f} px from the "
                                f"character in keyframe {k}",
                                "drag it onto the drawing (or paint the foreground mask there, if that is character)")
