"""The mask layers the annotation view shows: predicted masks (to start from) and refined masks (§4.1).

Predicted: the stored `key{k}/masks` output when it was computed from the current drawing and pose with
no manual mask and the same occlusion predictor (Settings.occlusion), otherwise the prediction itself (ops.segmentation.masks.build_masks without manual
masks), cached by the drawing's and pose's content versions. A shot the loader refuses still gets its
prediction from the drawing, skeleton and key pose alone. Refined: the stored `key{k}/refined_masks`,
with its boundaries as polylines; the page marks it stale when the plan says so.
"""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from ops.errors import ShotError
from ops.segmentation.masks import build_masks
from ops.settings import Settings
from ops.shotio.image_io import read_image, to_rgba
from ops.shotio.load import load_shot, parse_poses, parse_skeleton, read_shot_json
from ops.shotio.versions import source_versions
from ops.types import Masks, RefinedMasks, Shot, Skeleton
from resources.store import Store

from .shotfile import keyframe_names


def _stored_prediction(store: Store, partition: str, shot: Shot, k: int, sources: dict, occlusion: str
                       ) -> Masks | None:
    """key{k}/masks from the store if it predicted everything from exactly the current drawing and pose, with
    the same occlusion predictor."""
    name = f"key{k}/masks"
    digest, recorded = store.provenance(name, partition)
    if digest is None or not recorded or shot.foreground_masks[k] or shot.occlusion_masks[k]:
        return None
    if recorded.get("settings", {}).get("occlusion", occlusion) != occlusion:
        return None
    parents = recorded.get("parents", {})
    if any(parents.get(p) != sources[p] for p in (f"key{k}/drawing", f"key{k}/pose")):
        return None
    return store.read(name, partition)


def key_inputs(shot_dir: Path, k: int) -> tuple[Path, np.ndarray, Skeleton]:
    """(drawing path, key pose (J, 3), skeleton) of keyframe k from shot.json alone: a shot the loader refuses
    for another reason (a missing mask) still has a prediction to start from. ShotError if these are bad."""
    file, data = read_shot_json(shot_dir)
    skeleton = parse_skeleton(data, file)
    _, poses = parse_poses(data, file, skeleton)
    names = keyframe_names(data)
    if len(names) != 2:
        raise ShotError(file, "keyframes", "must list exactly two images", 'write "keyframes": ["key0.png", "key1.png"]')
    return file.parent / names[k], poses[0 if k == 0 else -1], skeleton


class Predictions:
    """Predicted masks per keyframe, keyed by what they are computed from."""

    def __init__(self, store: Store, partition: str, occlusion: str = Settings().occlusion):
        self.store, self.partition, self.occlusion = store, partition, occlusion
        self._cache: dict[tuple, tuple[Masks, str]] = {}
        self._lock = threading.Lock()

    def get(self, shot_dir: Path, k: int) -> tuple[Masks, str]:
        """(masks, "store" | "computed") for keyframe k of the saved shot."""
        try:
            shot = load_shot(shot_dir)
        except ShotError:
            shot = None
        if shot is not None:
            sources = source_versions(shot)
            key = (k, sources[f"key{k}/drawing"], sources[f"key{k}/pose"])
            drawing_path, pose, skeleton = shot.keyframes[k], shot.key_pose(k), shot.skeleton
        else:
            drawing_path, pose, skeleton = key_inputs(shot_dir, k)
            key = (k, Path(drawing_path).stat().st_mtime_ns, pose.round(6).tobytes())
        with self._lock:
            if key in self._cache:
                return self._cache[key]
            stored = (_stored_prediction(self.store, self.partition, shot, k, sources, self.occlusion)
                      if shot is not None else None)
            if stored is not None:
                out = (stored, "store")
            else:
                drawing = to_rgba(read_image(drawing_path, f"keyframes[{k}]"))
                out = (build_masks(drawing, pose, skeleton, occlusion=self.occlusion), "computed")
            self._cache = {key: out, **{c: v for c, v in self._cache.items() if c[0] != k}}
            return out


def _polyline(p: np.ndarray) -> list[list[float]]:
    return np.round(np.asarray(p, float).reshape(-1, 2), 2).tolist()


def refined_json(refined: RefinedMasks) -> dict:
    """Boundaries (closed polylines, pixels) and the snapped T-junctions of each region, and the outlines of the
    area the template meshes (its holes' included), as JSON."""
    return {"regions": len(refined.occlusion),
            "boundaries": [_polyline(b) for b in refined.boundaries],
            "domain": [_polyline(p) for p in refined.domain],
            "junctions": [_polyline(b[j]) for b, j in zip(refined.boundaries, refined.junctions)],
            "warnings": list(refined.warnings)}
