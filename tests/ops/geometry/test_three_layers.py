"""Three local layers (issue 27): both forearms folded over the chest in an X. The top forearm's region covers the
lower forearm and the chest, the lower forearm's covers the chest, and the two regions share the crossing, where
three sheets lie on each other at rest: the top forearm, the lower forearm, the chest."""
import copy

import cv2
import numpy as np
import pytest

from ops.appearance.inpaint import make_inpainter
from ops.appearance.lane import texture_lane
from ops.appearance.render import Renderer
from ops.geometry.deform import Deformer, count_flipped
from ops.geometry.mesh import boundary_loops, vertex_components
from ops.geometry.polygon import points_in_polygon
from ops.geometry.template import build_template
from ops.geometry.topology import Solver, alternating, incise, optimize_topology, region_key
from ops.types import RefinedMasks, Skeleton
from tests.ops.geometry.test_template import capsule

JOINTS = ("hips", "neck", "l_shoulder", "l_elbow", "l_hand", "r_shoulder", "r_elbow", "r_hand")
L_FOREARM, R_FOREARM = 3, 6  # bone i ends at joint i + 1
CROSSING = np.array([64.0, 67.5])  # where the forearms cross, on the torso's bone


def folded_arms(order=("left", "right")):
    """128 px: a torso capsule, the left forearm over the right one over the chest (z -2, -1, 0); at the other
    pose both hands swing down and out, uncrossing the arms. `order` lists the regions as the masks give them."""
    sk = Skeleton(joints=JOINTS, parents=np.array([-1, 0, 1, 2, 3, 1, 5, 6]))
    pose0 = np.array([[64, 112, 0], [64, 23, 0], [90, 34, -2], [92, 55, -2], [36, 80, -2],
                      [38, 34, -1], [36, 55, -1], [92, 80, -1]], float)
    pose1 = pose0.copy()
    pose1[4, :2] = [100.0, 88.0]  # the left hand down beside the right hip... of the drawing: the arms part
    pose1[7, :2] = [28.0, 88.0]
    torso = capsule(pose0[0, :2], pose0[1, :2], 34, 4)
    arms = {"left": _dense(capsule(pose0[3, :2], pose0[4, :2], 6, 2)),
            "right": _dense(capsule(pose0[6, :2], pose0[7, :2], 6, 2))}
    bones = {"left": L_FOREARM, "right": R_FOREARM}
    shape = (128, 128)

    def fill(poly):
        m = np.zeros(shape, np.uint8)
        cv2.fillPoly(m, [np.round(poly).astype(np.int32)], 1)
        return m.astype(bool)

    fg = fill(torso)
    refined = RefinedMasks(
        foreground=fg, occlusion=[fill(arms[o]) for o in order], front_bones=[np.array([bones[o]]) for o in order],
        boundaries=[arms[o] for o in order], junctions=[np.zeros(0, np.int64) for _ in order], domain=[torso],
        domain_holes=np.zeros((0, 2)), coverage=fg.astype(np.float32),
        paper=np.ones(shape + (3,), np.float32), colour=_colours(fg, fill(arms["left"]), fill(arms["right"])),
        nest_groups=[0, 0],  # one stack, as nesting (or two painted masks) says
    )
    return refined, sk, pose0, pose1


def _dense(P, step=3.0):
    """The closed polyline P (n, 2) with vertices at most `step` px apart along its edges (T-junctions are vertices)."""
    out = []
    for a, b in zip(P, np.roll(P, -1, axis=0)):
        k = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        out.append(a + np.arange(k)[:, None] / k * (b - a))
    return np.concatenate(out)


def _colours(fg, left, right):
    """(H, W, 3) chest grey, the right forearm blue, the left forearm red on top."""
    c = np.ones(fg.shape + (3,), np.float32)
    c[fg] = (0.6, 0.6, 0.6)
    c[right] = (0.2, 0.3, 0.9)
    c[left] = (0.9, 0.2, 0.2)
    return c


def test_overlapping_regions_are_stacked_front_to_back_by_depth(midpoint_handles):
    for order in (("left", "right"), ("right", "left")):
        refined, sk, pose, _ = folded_arms(order)
        base = build_template(refined, pose, sk)
        left = order.index("left")
        assert base.nested[0, 1] and base.nested[1, 0]
        assert base.stack.tolist() == [left, 1 - left]  # the left forearm (z -2) in front, whatever the order
        shared = np.intersect1d(base.region_faces[0], base.region_faces[1])
        assert len(shared) >= 6 and np.linalg.norm(base.V[base.F[shared]].mean(axis=(0, 1)) - CROSSING) < 3
        assert any("stacked front to back" in w for w in base.warnings)
    # regions of no common nest group overlap by accident: the earlier keeps the shared faces, as before
    refined.nest_groups = [-1, -1]
    base = build_template(refined, pose, sk)
    assert not base.nested.any() and not np.intersect1d(base.region_faces[0], base.region_faces[1]).size
    assert any("kept the earlier" in w for w in base.warnings)


def test_the_crossing_holds_three_sheets_and_the_chest_has_no_hole(midpoint_handles):
    refined, sk, pose, _ = folded_arms()
    base = build_template(refined, pose, sk)
    inc = incise(base, [alternating(np.zeros(0, np.int64), 1)] * 2)  # both fronts cut free, pockets sewn
    assert count_flipped(inc.rest, inc.faces) == 0
    # every shared face is there three times: the front sheet, the left forearm's pocket, the right forearm's
    shared = np.intersect1d(base.region_faces[0], base.region_faces[1])
    centroids = np.round(inc.rest[inc.faces].mean(axis=1), 6)
    for f in shared:
        at = np.flatnonzero((centroids == np.round(base.V[base.F[f]].mean(axis=0), 6)).all(axis=1))
        assert sorted(inc.face_layer[at].tolist()) == [0, 1, 2]
    # three pieces: the left forearm, the right forearm (its front sheet and its stretch in the left's pocket),
    # and the chest (the front sheet around, both pockets), which is whole: one outline, no hole at the crossing
    comp = vertex_components(len(inc.rest), inc.faces)
    face_comp = comp[inc.faces[:, 0]]
    assert len(np.unique(face_comp)) == 3
    chest = face_comp == face_comp[inc.face_layer == 2][0]
    assert len(boundary_loops(inc.faces[chest])) == 1
    assert np.isclose(_area(inc.rest, inc.faces[chest]), _area(base.V, base.F))
    # handles: the three bones' midpoints all lie at the crossing, one rest point; each descends to its own sheet:
    # the left forearm's stays on the front sheet, the right's goes into the left's pocket, the torso's under both
    mids = {"torso": 8 + 0, "left": 8 + L_FOREARM, "right": 8 + R_FOREARM}
    assert all(np.linalg.norm(base.V[base.handle_vertex[h]] - CROSSING) < 1e-6 for h in mids.values())
    assert {k: int(base.handle_layer[h]) for k, h in mids.items()} == {"torso": 2, "left": 0, "right": 1}
    pieces = {k: np.unique(face_comp[np.isin(inc.faces, inc.handles[h]).any(axis=1)]) for k, h in mids.items()}
    assert all(len(p) == 1 for p in pieces.values()) and len({int(p[0]) for p in pieces.values()}) == 3
    assert pieces["torso"][0] == face_comp[chest][0]


def _area(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.abs(0.5 * ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])).sum())


@pytest.fixture(scope="module")
def uncrossed():
    """The template optimized for the folded arms, textured, and rendered at the pose where the arms part."""
    refined, sk, pose0, pose1 = folded_arms()
    tpl = optimize_topology(refined, pose0, pose1, sk)
    textured, _ = texture_lane(tpl, refined, None, pose0, None, make_inpainter("telea", 3))
    d = Deformer(tpl.rest, tpl.faces, tpl.handles)
    x = d.solve(tpl.handle_targets(pose1)).x
    return refined, tpl, textured, x, pose0, pose1


def test_the_arms_part_without_folds_and_the_chest_shows_where_they_crossed(uncrossed):
    refined, tpl, textured, x, pose0, pose1 = uncrossed
    assert count_flipped(x, tpl.faces) == 0
    # the keyframe comes back exact
    rgba = Renderer(textured).frame(tpl.rest, pose0, supersample=1)[0]
    inside = cv2.erode(refined.foreground.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # the outline's fringe
    #                                                                                          is soft
    assert np.abs(rgba[inside][:, :3] - refined.colour[inside]).max() < 0.02
    # parted: the crossing shows the chest (opaque, grey-ish from the inpainting), not the paper
    rgba = Renderer(textured).frame(x, pose1, supersample=1)[0]
    cy, cx = np.round(CROSSING[::-1]).astype(int)
    patch = rgba[cy - 2:cy + 3, cx - 2:cx + 3]
    assert (patch[..., 3] > 0.99).all()
    assert np.abs(patch[..., :3] - 0.6).max() < 0.15
    # the right forearm's stretch that lay under the left one is the right forearm's blue, not the chest's grey
    # around the crossing nor the left forearm's red: inpainted from what its own sheet shows
    mid = np.round((pose1[6, :2] + pose1[7, :2]) / 2).astype(int)  # its midpoint, the crossing's at rest
    colour = rgba[mid[1] - 1:mid[1] + 2, mid[0] - 1:mid[0] + 2, :3].reshape(-1, 3).mean(axis=0)
    assert np.abs(colour - [0.2, 0.3, 0.9]).max() < 0.15, colour
    # two hidden sheets lie at the crossing's rest pixels: two back levels, side by side
    assert textured.back_texture.shape[1] == 2 * 128 and textured.back_level.max() == 1


def test_t_junctions_where_the_lower_forearm_passes_under_the_top_one():
    """Switch vertices of the nested region lie in the top region's pocket: each of its cuts incises without a fold
    or an edge of three faces, and the searched template parts the arms without a fold."""
    refined, sk, pose0, pose1 = folded_arms()
    under = points_in_polygon(refined.boundaries[1], refined.boundaries[0])  # the right forearm's outline under
    ends = np.flatnonzero(under & ~np.roll(under, 1)), np.flatnonzero(under & ~np.roll(under, -1))  # the left's
    refined.junctions[1] = np.sort(np.concatenate(ends))
    assert len(refined.junctions[1]) == 4
    base = build_template(refined, pose0, sk)
    for top in (0, 1):
        for low in (0, 1):
            inc = incise(base, [alternating(np.zeros(0, np.int64), top), alternating(base.junctions[1], low)])
            assert count_flipped(inc.rest, inc.faces) == 0 and inc.warnings == []
            # at each T-junction (inside the top forearm's area) the lower region's pocket (layer 2) is sewn to
            # the level above it there, the top one's pocket (layer 1): one vertex both use
            for p in base.V[base.boundary_vertex[1][base.junctions[1]]]:
                at = np.flatnonzero(np.linalg.norm(inc.rest - p, axis=1) < 1e-9)
                layers_of = [set(inc.face_layer[np.isin(inc.faces, v).any(axis=1)].tolist()) for v in at]
                assert any({1, 2} <= s for s in layers_of)
    tpl = optimize_topology(refined, pose0, pose1, sk)
    x = Deformer(tpl.rest, tpl.faces, tpl.handles).solve(tpl.handle_targets(pose1)).x
    assert np.isfinite(tpl.energy) and count_flipped(x, tpl.faces) == 0
    assert [c.tolist() for c in tpl.cut_switches][1] == refined.junctions[1].tolist()


def test_a_nested_regions_kept_cut_is_searched_again_when_its_partner_changes():
    """region_key reads the other regions of a nest group (they decide the level a pocket is made at); a region of
    no group keeps the key it had."""
    refined, sk, pose0, pose1 = folded_arms()
    keys = [region_key(refined, r, pose0, [pose1], "optimized", Solver()) for r in range(2)]
    moved = copy.deepcopy(refined)
    moved.boundaries[1] = moved.boundaries[1] + [1.0, 0.0]  # the lower forearm's outline one pixel over
    assert region_key(moved, 0, pose0, [pose1], "optimized", Solver()) != keys[0]
    assert region_key(moved, 1, pose0, [pose1], "optimized", Solver()) != keys[1]
    refined.nest_groups, moved.nest_groups = [-1, -1], [-1, -1]
    assert region_key(refined, 0, pose0, [pose1], "optimized", Solver()) == \
        region_key(moved, 0, pose0, [pose1], "optimized", Solver())
