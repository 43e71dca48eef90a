"""Layers that overlap at rest are ordered as wholes (ops.appearance.layers)."""
from __future__ import annotations

import numpy as np

from ops.appearance.layers import layer_depth, layer_groups, region_of_front_faces
from ops.appearance.render import render
from tests.ops.appearance.test_render import make_template, textured


def _brute_region_of_front_faces(tpl) -> np.ndarray:
    """The definition, face by face: a front-sheet face is in region r when a layer r + 1 face shares its centroid."""
    c = tpl.rest[tpl.faces].mean(axis=1)
    out = np.full(len(tpl.faces), -1, np.int64)
    for f in np.nonzero(tpl.face_layer == 0)[0]:
        for g in np.nonzero(tpl.face_layer > 0)[0]:
            if np.allclose(c[f], c[g], atol=1e-5):
                out[f] = tpl.face_layer[g] - 1
    return out


def test_region_of_front_faces_matches_brute_force():
    tpl = make_template(64)
    fast = region_of_front_faces(tpl)
    assert np.array_equal(fast, _brute_region_of_front_faces(tpl))
    assert (fast == 0).sum() == (tpl.face_layer == 1).sum()  # the pocket copies exactly the region's faces


def test_layer_groups_and_their_mean_depth():
    tpl = make_template(64)
    groups = layer_groups(tpl)
    assert set(np.unique(groups)) == {-1, 0, 1}
    assert np.array_equal(groups == 1, tpl.face_layer == 1)
    rng = np.random.default_rng(0)
    depth = rng.normal(size=len(groups))
    out = layer_depth(depth, groups)
    for g in (0, 1):
        assert np.allclose(out[groups == g], depth[groups == g].mean())
    assert np.array_equal(out[groups == -1], depth[groups == -1])


def test_a_layer_in_front_on_average_hides_the_other_everywhere():
    """Per-face depths that interleave (some pocket faces nearer, some farther than the sheet) must not let the
    back layer poke through: the pocket, nearer on average, covers its whole region."""
    size = 64
    tpl = make_template(size)
    tex = textured(tpl, size, source=2)
    pocket = tpl.face_layer > 0
    n = tpl.rest.shape[0]
    # per-vertex weights that make the pocket's faces alternate around a mean depth below the sheet's
    W = np.zeros((n, 2))
    W[:, 0] = 1.0
    verts = np.unique(tpl.faces[pocket])
    only_pocket = np.setdiff1d(verts, np.unique(tpl.faces[~pocket]))
    W[only_pocket[::2], :] = (0.0, 1.0)
    tex.weights = W
    pose = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -3.0]])
    face_depth = tex.face_depth(pose)
    assert face_depth[pocket].max() == 0.0 and face_depth[pocket].mean() < 0.0  # ties the sheet in places
    rgba, _ = render(tex, tpl.rest, pose)
    inside = rgba[28:37, 28:37, :3]
    assert (np.abs(inside - np.array([1.0, 0.0, 0.0])).max(axis=2) < 1e-3).all()
