"""Tests of depth weights (bbw), pocket texturing and the inpainter."""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from ops.appearance import weights as tex_mod
from ops.appearance.inpaint import OpenCVInpainter
from ops.appearance.render import rasterize_ids
from ops.appearance.texture import drawing_faces, subdivision_barycentrics, texture_template
from ops.appearance.weights import depth_weights, harmonic_weights
from ops.types import RefinedMasks
from tests.ops.appearance.test_render import make_template, pattern, square_foreground


def refined(fg: np.ndarray, drawing: np.ndarray, occlusion=()) -> RefinedMasks:
    """The masks texturing reads: foreground, occlusion regions, and the drawing as the character's colour with
    the foreground as coverage, on white paper."""
    return RefinedMasks(foreground=fg, occlusion=list(occlusion), front_bones=[], boundaries=[], junctions=[],
                        domain=[], domain_holes=np.zeros((0, 2)), coverage=fg.astype(np.float32),
                        paper=np.ones(fg.shape + (3,), np.float32), colour=np.asarray(drawing, np.float32)[..., :3])


FLAT = np.zeros((3, 3))  # every joint at depth 0: on ties the front sheet shows the drawing


def _check_weights(tpl, W):
    """Rows sum to 1, entries in [0, 1], handle rows equal their boundary conditions."""
    assert W.shape == (tpl.rest.shape[0], tpl.handle_weights.shape[1])
    assert np.allclose(W.sum(axis=1), 1.0, atol=1e-12)
    assert W.min() >= 0.0 and W.max() <= 1.0
    assert np.allclose(W[tpl.handles], tpl.handle_weights, atol=1e-12)


def test_bbw_weights_on_sewn_pocket_mesh(monkeypatch):
    tpl = make_template()
    # bbw itself must succeed on a mesh whose pocket is sewn along one side (non-manifold seam)
    monkeypatch.setattr(tex_mod, "harmonic_weights", lambda *a: (_ for _ in ()).throw(AssertionError("fallback")))
    W = depth_weights(tpl)
    _check_weights(tpl, W)
    # locality: vertices close to a joint are dominated by it
    for j in range(3):
        near = np.linalg.norm(tpl.rest - tpl.rest[tpl.handles[j]], axis=1) < 3.0
        assert (W[near, j] > 0.5).all()


def test_depth_at_joint_equals_joint_depth():
    tpl = make_template()
    W = depth_weights(tpl)
    z = np.array([0.3, -1.2, 2.5])
    depth = W @ z
    assert np.allclose(depth[tpl.handles[:3]], z)
    assert np.isclose(depth[tpl.handles[3]], 0.5 * (z[0] + z[1]))  # bone midpoint handle
    assert depth.min() >= z.min() - 1e-12 and depth.max() <= z.max() + 1e-12


def test_bbw_time_1500_vertices():
    tpl = make_template(384, lo=31.5, pocket=(140.0, 140.0, 240.0, 240.0), step=12.0, max_area=60.0)
    assert 1300 < tpl.rest.shape[0] < 1800
    t0 = time.perf_counter()
    W = depth_weights(tpl)
    elapsed = time.perf_counter() - t0
    print(f"depth_weights: {tpl.rest.shape[0]} vertices in {elapsed:.3f} s")
    _check_weights(tpl, W)
    assert elapsed < 1.0


def test_harmonic_fallback_when_bbw_fails(monkeypatch):
    tpl = make_template()

    def broken(*args, **kwargs):
        raise RuntimeError("active set failed")

    monkeypatch.setattr(tex_mod.igl, "bbw", broken)
    W = depth_weights(tpl)
    _check_weights(tpl, W)
    H = harmonic_weights(tpl.rest, tpl.faces, tpl.handles, tpl.handle_weights)
    H = np.clip(H, 0, 1)
    assert np.allclose(W, H / H.sum(axis=1, keepdims=True))


def test_component_without_handles_follows_nearest_handle():
    tpl = make_template()
    n = tpl.rest.shape[0]
    island = np.array([[3.0, 30.0], [5.0, 30.0], [4.0, 33.0]])  # left of joint 0, not connected
    faces = np.concatenate([tpl.faces, [[n, n + 1, n + 2]]])
    tpl2 = replace(tpl, rest=np.concatenate([tpl.rest, island]), faces=faces,
                   face_layer=np.concatenate([tpl.face_layer, [0]]))
    W = depth_weights(tpl2)
    _check_weights(tpl2, W)
    assert np.allclose(W[n:], [1.0, 0.0, 0.0])
    assert np.allclose(W[:n], depth_weights(tpl))


def test_subdivision_samples_are_uniform():
    b = subdivision_barycentrics(4)
    assert b.shape == (16, 3) and np.allclose(b.sum(axis=1), 1) and (b > 0).all()
    assert np.allclose(b.mean(axis=0), 1 / 3)  # centroid of the samples = centroid of the triangle


SHIFT = np.array([5.0, 2.0])  # the other keyframe = this drawing translated by (+5, +2) px


def _shot(size=64, occlusion_x=37):
    """Drawing, foreground and the other keyframe translated by SHIFT, occluded where x >= occlusion_x."""
    drawing = pattern(size)
    fg = square_foreground(size, 7.5)
    other = np.roll(drawing, (2, 5), axis=(0, 1))
    other_fg = np.roll(fg, (2, 5), axis=(0, 1))
    occ = other_fg.copy()
    occ[:, :occlusion_x] = False
    return drawing, fg, other, other_fg, [occ]


def _expected_visible_fraction(tpl, pockets, occlusion_x, samples=2000):
    """Monte Carlo: fraction of each deformed pocket face left of the occlusion edge (x < occlusion_x - 0.5)."""
    rng = np.random.default_rng(0)
    u, v = rng.random((2, samples))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    tri = (tpl.rest + SHIFT)[tpl.faces[pockets]]
    x = tri[:, 0, 0, None] * (1 - u - v) + tri[:, 1, 0, None] * u + tri[:, 2, 0, None] * v
    return (x < occlusion_x - 0.5).mean(axis=1)


def test_texture_template_sources_and_back_texture():
    size = 64
    tpl = make_template(size)
    drawing, fg, other, other_fg, occ = _shot(size)
    tt = texture_template(tpl, depth_weights(tpl), refined(fg, drawing), refined(other_fg, other, occ), FLAT,
                          tpl.rest + SHIFT, OpenCVInpainter())
    # front texture: the drawing, alpha = coverage (here the foreground; on white paper nothing to unmix)
    inside = fg.astype(bool)
    assert np.allclose(tt.texture[inside][:, :3], drawing[inside], atol=1e-6)
    assert np.array_equal(tt.texture[..., 3], fg.astype(np.float32))
    pockets = np.nonzero(tpl.face_layer > 0)[0]
    assert (tt.face_source[tpl.face_layer == 0] == 0).all()
    frac = _expected_visible_fraction(tpl, pockets, 37)
    clear = np.abs(frac - 0.5) > 0.1
    expected = np.where(frac >= 0.5, 1, 2)
    assert np.array_equal(tt.face_source[pockets][clear], expected[clear])
    assert {1, 2} <= set(tt.face_source[pockets].tolist())
    # visible part of the pocket (rest x <= 30 -> other x <= 35): the other drawing, warped back exactly
    ids = rasterize_ids(tpl.rest, tpl.faces, pockets, (size, size))
    region = np.zeros((size, size), bool)
    region[25:40, 25:31] = True
    ok = region & (tt.face_source[np.maximum(ids, 0)] == 1)
    assert ok.sum() > 50
    assert np.abs(tt.back_texture[ok][:, :3] - drawing[ok]).max() < 1e-5
    assert not tt.back_inpainted[ok].any()
    # hidden part (rest x >= 33 -> other x >= 38) and every pixel of a source-2 face are inpainted
    hidden = np.zeros((size, size), bool)
    hidden[24:41, 33:41] = True
    assert tt.back_inpainted[hidden].all()
    assert tt.back_inpainted[(ids >= 0) & (tt.face_source[np.maximum(ids, 0)] == 2)].all()
    # the back texture is opaque over the pockets (plus a margin) and empty elsewhere
    assert (tt.back_texture[24:41, 24:41, 3] == 1).all()
    assert (tt.back_texture[:16, :, 3] == 0).all() and (tt.back_texture[:, 48:, 3] == 0).all()
    assert np.isfinite(tt.back_texture).all() and tt.back_texture.min() >= 0 and tt.back_texture.max() <= 1


def test_pocket_carried_onto_the_other_keyframes_paper_is_transparent():
    """A pocket larger than what hides behind it (a near leg's whole outline over a thinner far leg): where the
    deformation carries it onto the other keyframe's paper it is no character, not an inpainted opaque edge."""
    size = 64
    tpl = make_template(size)
    drawing, fg, other, other_fg, _ = _shot(size)
    other_fg = other_fg.copy()
    other_fg[:, 38:] = False  # the other keyframe ends at x = 38: rest x >= 33 lands on its paper
    other_masks = refined(other_fg, other)
    tt = texture_template(tpl, depth_weights(tpl), refined(fg, drawing), other_masks, FLAT, tpl.rest + SHIFT,
                          OpenCVInpainter())
    pockets = np.nonzero(tpl.face_layer > 0)[0]
    covered = rasterize_ids(tpl.rest, tpl.faces, pockets, (size, size)) >= 0
    on_paper = covered.copy()
    on_paper[:, :34] = False
    on_drawing = covered.copy()
    on_drawing[:, 31:] = False
    assert on_paper.sum() > 50 and on_drawing.sum() > 50
    assert (tt.back_texture[on_paper, 3] == 0).all() and not tt.back_inpainted[on_paper].any()
    assert (tt.back_texture[on_drawing, 3] == 1).all()
    assert np.abs(tt.back_texture[on_drawing][:, :3] - drawing[on_drawing]).max() < 1e-5
    # the fringe between takes the other drawing's coverage (here its hard edge, bilinearly sampled)
    assert 0 < tt.back_texture[covered & ~on_paper & ~on_drawing, 3].max() <= 1


def test_fully_occluded_pockets_are_inpainted_from_context():
    size = 64
    tpl = make_template(size)
    colour = np.array([0.2, 0.6, 0.4], np.float32)
    drawing = np.broadcast_to(colour, (size, size, 3)).copy()
    fg = square_foreground(size, 7.5)
    # the other keyframe hides everything: every pocket face is inpainted from the constant drawing around it
    tt = texture_template(tpl, depth_weights(tpl), refined(fg, drawing), refined(fg, drawing, [fg]), FLAT, tpl.rest,
                          OpenCVInpainter())
    assert (tt.face_source[tpl.face_layer > 0] == 2).all()
    pocket_px = tt.back_texture[..., 3] > 0
    assert tt.back_inpainted[pocket_px].all()
    assert np.abs(tt.back_texture[pocket_px][:, :3] - colour).max() < 2.5 / 255  # telea works on 8 bits


def test_template_without_pockets_has_empty_back():
    tpl = make_template()
    front = tpl.face_layer == 0
    used = np.unique(tpl.faces[front])
    remap = np.full(tpl.rest.shape[0], -1)
    remap[used] = np.arange(used.size)
    flat = replace(tpl, rest=tpl.rest[used], faces=remap[tpl.faces[front]], face_layer=tpl.face_layer[front],
                   handles=remap[tpl.handles])
    drawing, fg, other, other_fg, occ = _shot()
    tt = texture_template(flat, depth_weights(flat), refined(fg, drawing), refined(other_fg, other, occ), FLAT,
                          flat.rest + SHIFT, OpenCVInpainter())
    assert (tt.face_source == 0).all() and (tt.back_texture == 0).all() and not tt.back_inpainted.any()


def test_opencv_inpainter_fills_only_the_hole():
    rng = np.random.default_rng(2)
    image = np.full((40, 40, 3), 0.3, np.float32)
    image[:, 20:] = 0.7
    image += rng.uniform(-0.01, 0.01, image.shape).astype(np.float32)
    hole = np.zeros((40, 40), bool)
    hole[10:20, 5:12] = True  # inside the 0.3 half
    for method in ("telea", "ns"):
        out = OpenCVInpainter(radius=3, method=method)(image, hole)
        assert np.array_equal(out[~hole], image[~hole])
        assert np.abs(out[hole] - 0.3).max() < 0.03
    assert np.array_equal(OpenCVInpainter()(image, np.zeros((40, 40), bool)), image)
    with pytest.raises(ValueError):
        OpenCVInpainter(method="lama")


def test_inpainter_resource_builds_configured_inpainter():
    from resources.inpainter import InpainterResource

    inp = InpainterResource(method="ns", radius=3).get()
    assert isinstance(inp, OpenCVInpainter) and inp.method == "ns" and inp.radius == 3
    with pytest.raises(ValueError):
        InpainterResource(method="bogus").get()


@pytest.mark.parametrize("pocket_z", [-1.0, 1.0])
def test_rendered_inpainted_mask_follows_visible_inpainted_pocket(pocket_z):
    from ops.appearance.render import render
    from tests.ops.appearance.test_render import textured

    size = 64
    tpl = make_template(size)
    drawing, fg, other, other_fg, occ = _shot(size)
    tt = texture_template(tpl, depth_weights(tpl), refined(fg, drawing), refined(other_fg, other, occ), FLAT,
                          tpl.rest + SHIFT, OpenCVInpainter())
    tt = replace(tt, weights=textured(tpl, size).weights)  # front sheet on joint 0, pocket on joint 1
    pose = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, pocket_z]])
    rgba, inpainted = render(tt, tpl.rest, pose)
    if pocket_z > 0:  # pocket behind the front sheet: nothing inpainted shows
        assert not inpainted.any()
        return
    # pocket in front: its hidden (inpainted) right part shows, its left part has the other keyframe's texture
    assert inpainted[26:39, 34:39].all()
    assert not inpainted[26:39, 25:30].any()
    assert not inpainted[:, :23].any() and not inpainted[:, 42:].any()
    assert np.abs(rgba[26:39, 25:30, :3] - drawing[26:39, 25:30]).max() < 0.02


def test_the_layer_nearer_at_the_keyframe_shows_the_drawing():
    """§5.1: per region, the layer with the smaller mean depth at the key pose gets the drawing, whichever it is."""
    from tests.ops.appearance.test_render import textured

    tpl = make_template(64)
    W = textured(tpl, 64).weights  # front sheet follows joint 0, the pocket joint 1
    sheet_in_region = (tpl.face_layer == 0) & np.isin(
        np.round(tpl.rest[tpl.faces].mean(1), 4).view([("x", float), ("y", float)]).ravel(),
        np.round(tpl.rest[tpl.faces[tpl.face_layer == 1]].mean(1), 4).view([("x", float), ("y", float)]).ravel())
    behind = drawing_faces(tpl, W, np.array([[0, 0, 0.0], [0, 0, 1.0]]))
    assert behind[tpl.face_layer == 0].all() and not behind[tpl.face_layer == 1].any()
    before = drawing_faces(tpl, W, np.array([[0, 0, 0.0], [0, 0, -1.0]]))
    assert before[tpl.face_layer == 1].all() and not before[sheet_in_region].any()
    assert before[(tpl.face_layer == 0) & ~sheet_in_region].all()


def test_texture_hands_the_inpainter_the_context_coverage():
    """An inpainter that takes coverage gets what the context shows of the character (0 off it); one written
    for the first protocol is called without it."""
    size = 64
    tpl = make_template(size)
    drawing = np.broadcast_to(np.array([0.2, 0.6, 0.4], np.float32), (size, size, 3)).copy()
    fg = square_foreground(size, 7.5)
    calls = {}

    def modern(image, hole, coverage=None):
        calls["modern"] = coverage
        return OpenCVInpainter()(image, hole)

    def legacy(image, hole):
        calls["legacy"] = True
        return OpenCVInpainter()(image, hole)

    for inp in (modern, legacy):
        texture_template(tpl, depth_weights(tpl), refined(fg, drawing), refined(fg, drawing, [fg]), FLAT, tpl.rest, inp)
    cov = calls["modern"]
    assert cov.shape == fg.shape and np.array_equal(cov > 0.5, fg) and calls["legacy"]


def test_a_joints_weight_does_not_reach_across_a_slit():
    """Issue 27: a handle's weights must not reach across a cut into the body beside it. An arm hangs along a torso,
    the two drawn touching (one foreground); the contact's slit cuts the mesh between them. Half-way down the slit
    the hand's weight on the torso's side is a small share of its weight on the arm's side, where without the slit
    the two sides weigh about the same (the weights follow the mesh, not the plane)."""
    from types import SimpleNamespace

    import cv2

    from ops.geometry.template import build_template
    from ops.types import Skeleton
    from tests.ops.geometry.test_template import capsule

    sk = Skeleton(joints=("hips", "neck", "shoulder", "elbow", "hand"), parents=np.array([-1, 0, 1, 2, 3]))
    pose = np.array([[64, 100, 0], [64, 30, 0], [86, 36, 0], [89, 64, 0], [90, 92, 0]], float)
    torso = capsule(pose[0, :2], pose[1, :2], 20.0, 3.0)
    arm = capsule(pose[2, :2], pose[4, :2], 6.0, 2.0)
    fg = np.zeros((128, 128), np.uint8)
    cv2.fillPoly(fg, [np.round(torso).astype(np.int32)], 1)
    cv2.fillPoly(fg, [np.round(arm).astype(np.int32)], 1)
    outline = cv2.findContours(fg, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)[0][0][:, 0].astype(np.float64)
    # the contact's slit runs down the shared edge and out through the notch where the arm leaves the torso, as
    # slits near the outline are carried to it (ops.segmentation.slits)
    notch = outline[np.argmin(np.linalg.norm(outline - (84.0, 97.0), axis=1))]
    slit = np.concatenate([np.stack([np.full(15, 84.0), np.linspace(48.0, 92.0, 15)], axis=1), notch[None]])

    def hand_weight_beside_slit(slits):
        masks = RefinedMasks(foreground=fg.astype(bool), occlusion=[], front_bones=[], boundaries=[], junctions=[],
                             domain=[outline], domain_holes=np.zeros((0, 2)), coverage=fg.astype(np.float32),
                             paper=np.ones((128, 128, 3), np.float32), colour=np.ones((128, 128, 3), np.float32),
                             slits=slits)
        base = build_template(masks, pose, sk, max_area=4.0)
        doubled = len(base.V) - len(np.unique(np.round(base.V, 6), axis=0))  # the slit's vertices, one per side
        assert (doubled > 0) == bool(slits)
        W = depth_weights(SimpleNamespace(rest=base.V, faces=base.F, handles=base.handle_vertex,
                                          handle_weights=base.handle_weights))
        row = np.abs(base.V[:, 1] - 69.0) < 4.0
        torso_side = row & (base.V[:, 0] > 79.0) & (base.V[:, 0] < 83.5)
        arm_side = row & (base.V[:, 0] > 84.5) & (base.V[:, 0] < 89.0)
        assert torso_side.any() and arm_side.any()
        return W[torso_side, 4].mean(), W[arm_side, 4].mean()

    torso_w, arm_w = hand_weight_beside_slit([slit])
    assert torso_w < 0.02 * arm_w and arm_w > 0.1, (torso_w, arm_w)
    glued_torso, glued_arm = hand_weight_beside_slit([])
    assert glued_torso > 0.5 * glued_arm, (glued_torso, glued_arm)
