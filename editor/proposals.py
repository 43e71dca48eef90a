"""T-junction proposals the annotation view offers to accept (assets/run/junctions.py `key_proposals`).

Computed on demand per key and cached by what they are computed from (the key's drawing and pose versions and
the occlusion predictor), so asking again is instant; the clicks are not part of that: they only hide the
proposals within CLICK_WINS_PX of one (a click always wins), checked on every request.
"""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from assets.run.junctions import key_proposals, proposal_version
from ops.segmentation.junction_proposals import MIN_SCORE, JunctionProposals
from ops.settings import Settings
from ops.shotio.load import load_shot

CLICK_WINS_PX = 5.0  # a proposal this close to a clicked T-junction (pixels) is the click: not offered


def away_from_clicks(props: JunctionProposals, clicks: np.ndarray) -> np.ndarray:
    """(k,) bool: the proposals farther than CLICK_WINS_PX from every click ((n, 2) x, y pixels)."""
    clicks = np.asarray(clicks, float).reshape(-1, 2)
    if not len(props.points) or not len(clicks):
        return np.ones(len(props.points), bool)
    d = np.linalg.norm(props.points[:, None, :] - clicks[None, :, :2], axis=2)
    return d.min(axis=1) > CLICK_WINS_PX


class Proposals:
    """Each key's proposals, kept for the version they were computed from (one per key)."""

    def __init__(self, settings: Settings):
        self.settings = settings
        self._cache: dict[int, tuple[tuple, JunctionProposals]] = {}
        self._lock = threading.Lock()  # one computation at a time: the machine's cores are the reruns' too

    def get(self, shot_dir: Path, k: int) -> dict:
        """JSON of key k's proposals not near its saved clicks, best first, with "cached" (no computation)."""
        shot = load_shot(shot_dir)
        version = proposal_version(shot, k, self.settings)
        with self._lock:
            hit = self._cache.get(k)
            cached = hit is not None and hit[0] == version
            props = hit[1] if cached else key_proposals(shot, k, self.settings)
            self._cache[k] = (version, props)
        keep = away_from_clicks(props, shot.t_junctions[k])
        return {"key": k, "cached": cached, "min_score": MIN_SCORE, "click_wins_px": CLICK_WINS_PX,
                "hidden_by_clicks": int((~keep).sum()),
                "proposals": [{"x": round(float(x), 1), "y": round(float(y), 1), "score": round(float(s), 3),
                               "stem": [round(float(a), 3) for a in st], "region": int(r)}
                              for (x, y), s, st, r in zip(props.points[keep], props.scores[keep],
                                                          props.stems[keep], props.regions[keep])]}
