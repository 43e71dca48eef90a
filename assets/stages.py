"""Every stage any shot can have, declared without Dagster: a lane per key, each segment's two sides and its
blending (assets/graph.py), the shot's frames and the evaluation group. Importing this module fills
assets.compute.STAGE_SPECS, so a run can compute its stages (assets/ahead.py) while Dagster is still being
imported; assets/definitions.py makes the same declarations into Dagster assets."""
from __future__ import annotations

from ops.shotio.load import MAX_KEYS

from .blending import segment_stages, shot_stages
from .compute import StageDef
from .evaluation import evaluation_stages
from .geometry import lane_stages, side_stages
from .graph import segment_keys

SHOT_STAGES: list[StageDef] = [
    *(d for k in range(MAX_KEYS) for d in lane_stages(k)),
    *(d for s in range(MAX_KEYS - 1) for k in segment_keys(s, MAX_KEYS) for d in side_stages(s, k)),
    *(d for s in range(MAX_KEYS - 1) for d in segment_stages(s)),
    *shot_stages(),
]
EVALUATION_STAGES: list[StageDef] = evaluation_stages()
