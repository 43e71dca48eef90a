"""The refined-mask layer's JSON, from a real refinement (not a stand-in record)."""
from __future__ import annotations

import json

import numpy as np

from editor.layers import refined_json
from ops.segmentation.masks import build_masks
from ops.segmentation.refine import refine_masks
from tests.ops.segmentation.test_masks import crossing_scene


def test_refined_json_of_a_real_refinement_has_every_outline():
    """The page draws the regions' boundaries, their T-junctions and the meshed outlines; a field the masks no
    longer carry made /api/refined answer 500 on every run the editor opened."""
    drawing, pose, skeleton, *_ = crossing_scene()
    refined = refine_masks(build_masks(drawing, pose, skeleton), np.zeros((0, 2)), pose, skeleton)
    out = json.loads(json.dumps(refined_json(refined)))
    assert out["regions"] == len(refined.occlusion) >= 1
    assert len(out["domain"]) == len(refined.domain) >= 1
    assert all(np.allclose(a, np.round(b, 2)) for a, b in zip(out["domain"], refined.domain))
    assert len(out["boundaries"]) == len(out["junctions"]) == len(refined.boundaries)
