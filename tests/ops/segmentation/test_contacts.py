"""Tests of ops.segmentation.contacts: touching bodies found on the drawing's strokes, thin overlaps, slits."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ops.segmentation import contacts as contacts_mod
from ops.segmentation.contacts import drawn_bodies, stroke_contacts, thin_overlaps
from ops.segmentation.masks import build_masks
from ops.segmentation.refine import refine_masks
from ops.segmentation.slits import AVOID_PX, JOIN_PX, slit_of
from ops.types import Skeleton
from tests.ops.segmentation.test_masks import capsule, ink_drawing, outline

SAMPLES = Path(__file__).resolve().parents[3] / "data_samples"
SIZE = 160
SKELETON = Skeleton(("hips", "neck", "shoulder", "elbow", "hand"), np.array([-1, 0, 1, 2, 3]))


def hanging_arm(gap: float = 0.0):
    """A torso with an arm hanging along its left side, `gap` px apart (0: the outlines touch).

    The hand joint sits on the torso's outline, as drawn skeletons often put it.
    Returns (drawing, pose (5, 3), foreground).
    """
    shape = (SIZE, SIZE)
    torso = capsule(shape, (80, 40), (80, 125), 20)
    x = 51 - gap
    arm = capsule(shape, (x, 48), (x, 86), 8) | capsule(shape, (x, 86), (x, 122), 8)
    shoulder = capsule(shape, (x, 48), (66, 40), 6)  # the arm hangs from the torso's shoulder
    body = torso | arm | shoulder
    ink = outline(body) | outline(torso) | outline(arm)  # the arm is drawn whole, over the shoulder
    pose = np.array([[80, 125, 0], [80, 40, 0], [x, 48, -0.5], [x, 86, -0.5], [x + 8, 122, -0.5]], float)
    return ink_drawing(ink), pose, body


def test_an_arm_touching_the_torso_is_a_contact_along_the_shared_stroke():
    drawing, pose, fg = hanging_arm()
    pieces = stroke_contacts(drawing, fg, pose, SKELETON)
    assert pieces
    ys, xs = np.nonzero(np.any(pieces, axis=0))
    assert np.abs(xs - 59.5).max() <= 4  # on the shared stroke
    assert ys.max() - ys.min() >= 50  # most of the forearm and upper arm's length
    # down to the hand: its joint on the torso's outline must not hand the torso's pixels to the forearm
    assert ys.max() >= 112


def test_drawn_bodies_end_at_the_strokes_between_them():
    """The torso's pixels are the spine's and the clavicle's, the arm's the arm bones', parted by the stroke
    between them; strokes are nobody's."""
    drawing, pose, fg = hanging_arm(gap=3.0)
    owner = drawn_bodies(drawing, fg, pose, SKELETON)
    stroke = drawing[..., 0] < 0.5
    assert (owner[stroke] == -1).all()
    torso_core = capsule(fg.shape, (80, 40), (80, 125), 16)
    arm_core = capsule(fg.shape, (48, 55), (48, 118), 4)
    assert np.isin(owner[torso_core & ~stroke], [0, 1]).all()  # hips -> neck -> shoulder
    assert np.isin(owner[arm_core & ~stroke], [2, 3]).all()  # shoulder -> elbow -> hand


def test_the_torso_near_a_hand_on_its_outline_stays_the_torsos():
    """Without the compartments' rule (every bone holds every compartment: the nearest bone only), the torso's
    pixels near the hand go to the forearm and the contact stops short of the hand."""
    drawing, pose, fg = hanging_arm()
    with_rule = np.any(stroke_contacts(drawing, fg, pose, SKELETON), axis=0)
    original = contacts_mod.drawn_parts

    def every_bone_holds_all(*args):
        stroke, labels, holds = original(*args)
        holds = np.ones_like(holds)
        holds[:, 0] = False
        return stroke, labels, holds

    try:
        contacts_mod.drawn_parts = every_bone_holds_all
        without = stroke_contacts(drawing, fg, pose, SKELETON)
    finally:
        contacts_mod.drawn_parts = original
    lowest_without = np.nonzero(np.any(without, axis=0))[0].max() if without else 0
    assert np.nonzero(with_rule)[0].max() > lowest_without + 5


def test_an_arm_apart_from_the_torso_is_no_contact():
    drawing, pose, fg = hanging_arm(gap=8.0)
    assert stroke_contacts(drawing, fg, pose, SKELETON) == []


def painted_arm(x: float, close_px: int):
    """Watercolour, no ink anywhere: a pale arm painted with its right edge at x + 8 beside a pink torso whose
    left edge is at 60. Returns (drawing, painted (H, W) bool, the foreground closed by a close_px disc, pose)."""
    shape = (SIZE, SIZE)
    torso = capsule(shape, (80, 40), (80, 125), 20)
    arm = capsule(shape, (x, 48), (x, 86), 8) | capsule(shape, (x, 86), (x, 122), 8)
    shoulder = capsule(shape, (x, 48), (66, 40), 6)
    painted = torso | arm | shoulder
    drawing = np.ones(shape + (3,), np.float32)
    drawing[torso] = (0.93, 0.55, 0.65)  # pink top
    drawing[arm | shoulder] = (0.96, 0.84, 0.74)  # pale skin: lighter than the top, by less than a stroke
    closed = cv2.morphologyEx(painted.astype(np.uint8), cv2.MORPH_CLOSE,
                              cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (close_px, close_px))).astype(bool)
    pose = np.array([[80, 125, 0], [80, 40, 0], [x, 48, -0.5], [x, 86, -0.5], [x + 8, 122, -0.5]], float)
    return drawing, painted, closed, pose


def test_paper_glued_between_painted_bodies_is_a_contact():
    """Watercolour: an arm painted 3 px beside the torso. The mesh's foreground closes the gap; that glued
    paper is where the two bodies part. Without it nothing is found (paint has no strokes)."""
    drawing, painted, closed, pose = painted_arm(48.0, 9)  # the arm's right edge at 56, the torso's left at 60
    assert stroke_contacts(drawing, painted, pose, SKELETON) == []
    pieces = stroke_contacts(drawing, painted, pose, SKELETON, glued=closed & ~painted)
    assert pieces
    ys, xs = np.nonzero(np.any(pieces, axis=0))
    assert ((xs >= 56) & (xs <= 60)).all()  # in the gap (57-59) or on its edges
    assert ys.max() - ys.min() >= 50  # along the forearm and upper arm


def test_paper_glued_wider_than_both_sides_parts_the_bodies_along_its_middle():
    """A watercolour forearm 7 px off the waist, the gap closed over by the foreground: no pixel of the gap lies
    within SIDE_PX of both bodies, but its middle is within its half width plus SIDE_PX of each. Without the
    half width the arm stays glued to the torso along the whole gap."""
    drawing, painted, closed, pose = painted_arm(44.0, 13)  # the arm's right edge at 52
    gap = closed & ~painted
    assert gap[80, 53:60].all()  # the foreground closed the whole 7 px
    pieces = stroke_contacts(drawing, painted, pose, SKELETON, glued=gap)
    assert pieces
    ys, xs = np.nonzero(np.any(pieces, axis=0))
    assert ((xs >= 53) & (xs <= 59)).all()  # inside the gap
    assert ys.max() - ys.min() >= 50  # along the forearm and upper arm


def test_thin_overlap_along_a_contact_is_told_from_a_real_one():
    shape = (SIZE, SIZE)
    contact = np.zeros(shape, bool)
    contact[40:120, 60] = True
    band = np.zeros(shape, bool)
    band[100:118, 57:64] = True  # a hand's capsule dipping into the hip along the stroke
    wide = np.zeros(shape, bool)
    wide[90:120, 40:80] = True  # an arm across the body: most of it far from the stroke
    np.testing.assert_array_equal(thin_overlaps([band, wide], [contact]), [True, False])
    np.testing.assert_array_equal(thin_overlaps([band], []), [False])


def test_slit_of_a_contact_keeps_clear_of_regions_and_reaches_the_outline():
    contact = np.zeros((SIZE, SIZE), bool)
    contact[40:120, 60] = True
    outline_loop = np.array([[20.0, 37.0], [140.0, 37.0], [140.0, 150.0], [20.0, 150.0]])
    free = slit_of(contact, np.zeros_like(contact), [outline_loop])
    assert free is not None
    assert min(abs(free[0, 1] - 37.0), abs(free[-1, 1] - 37.0)) < 1e-6  # carried on to the outline
    region = np.zeros_like(contact)
    region[100:130, 50:70] = True
    blocked = slit_of(contact, region, [outline_loop])
    assert blocked[:, 1].max() < 100 - AVOID_PX + 1


def test_a_contact_cut_short_by_a_region_is_carried_on_to_its_t_junction():
    """A contact that runs on into an occlusion region keeps AVOID_PX clear of it; when a T-junction of the region
    lies within JOIN_PX of where it stops, the slit ends on that junction (no bridge of mesh is left between the
    two cuts), and then a short remainder is enough. Far from every junction it stays as before."""
    contact = np.zeros((SIZE, SIZE), bool)
    contact[95:112, 60] = True  # 17 px of stroke, the last 12 of them in or beside the region below
    region = np.zeros_like(contact)
    region[104:130, 50:70] = True
    loop = np.array([[20.0, 37.0], [140.0, 37.0], [140.0, 150.0], [20.0, 150.0]])
    assert slit_of(contact, region, [loop]) is None  # 4 px left outside: too short alone
    junction = np.array([[60.0, 103.5]])
    joined = slit_of(contact, region, [loop], junctions=junction)
    assert joined is not None
    ends = {tuple(joined[0]), tuple(joined[-1])}
    assert tuple(junction[0]) in ends  # ends exactly on the junction: a vertex of both cuts
    assert min(y for _, y in ends) == 95.0
    far = np.array([[60.0 + JOIN_PX + 8.0, 103.5]])
    assert slit_of(contact, region, [loop], junctions=far) is None
    whole = np.zeros_like(contact)
    whole[60:120, 60] = True  # long enough alone: joined at the region's end, the far end as before
    long_slit = slit_of(whole, region, [loop], junctions=junction)
    assert {tuple(long_slit[0]), tuple(long_slit[-1])} == {(60.0, 60.0), tuple(junction[0])}
    untouched = slit_of(whole, np.zeros_like(whole), [loop], junctions=junction)  # no region cut it short
    assert {untouched[0, 1], untouched[-1, 1]} == {60.0, 119.0}


def test_thin_hip_region_is_slit_not_pocketed_unless_clicked():
    """refine_masks drops an overlap region that only follows a contact, and keeps it when the user clicked a
    T-junction on it."""
    drawing, pose, _ = hanging_arm()
    masks = build_masks(drawing, pose, SKELETON)
    band = np.zeros_like(masks.foreground)
    band[104:118, 57:63] = True
    masks.occlusion, masks.front_bones = [band & masks.foreground], [np.array([3])]
    assert masks.contacts
    dropped = refine_masks(masks, np.zeros((0, 2)), pose, SKELETON)
    assert dropped.occlusion == [] and dropped.slits
    assert any("lies along a contact" in w for w in dropped.warnings)
    clicked = refine_masks(masks, np.array([[60.0, 104.0]]), pose, SKELETON)
    assert len(clicked.occlusion) == 1


def _raised(pose: np.ndarray, degrees: float) -> np.ndarray:
    """The pose with the arm (elbow, hand) turned about the shoulder by `degrees`, outward (to the left)."""
    out = pose.copy()
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    R = np.array([[c, -s], [s, c]])
    out[3:, :2] = (pose[3:, :2] - pose[2, :2]) @ R.T + pose[2, :2]
    return out


def _torso_stretch(refined, pose, other) -> float:
    """Worst stretch of the torso's faces (well inside the torso) when the template deforms to `other`."""
    from ops.geometry.deform import Deformer
    from ops.geometry.mesh import face_stretch
    from ops.geometry.topology import optimize_topology

    tpl = optimize_topology(refined, pose, other, SKELETON)
    X = Deformer(tpl.rest, tpl.faces, tpl.handles).solve(tpl.handle_targets(other)).x
    centre = tpl.rest[tpl.faces].mean(axis=1)
    torso = (tpl.face_layer == 0) & (centre[:, 0] > 62) & (centre[:, 1] > 75) & (centre[:, 1] < 120)
    return float(face_stretch(tpl.rest, X, tpl.faces)[torso].max())


def test_a_slit_arm_lifts_off_the_torso_without_stretching_it():
    """The arm turned 60 degrees out: with the contact slit the torso keeps its shape; glued, it is dragged."""
    drawing, pose, _ = hanging_arm()
    pose[4, 0] = 51.0  # the hand's joint inside the hand: a handle on the torso's side would hold it there
    masks = build_masks(drawing, pose, SKELETON)
    masks.occlusion, masks.front_bones = [], []  # the touch alone (the rule's capsules overlap the torso here)
    other = _raised(pose, 60.0)
    slit = _torso_stretch(refine_masks(masks, np.zeros((0, 2)), pose, SKELETON), pose, other)
    masks.contacts = []
    glued = _torso_stretch(refine_masks(masks, np.zeros((0, 2)), pose, SKELETON), pose, other)
    assert slit < 1.3 < glued


def test_a_stroke_inside_one_compartment_parts_nothing():
    """A fold drawn down a skirt between the two thighs, ending inside it, has the skirt on both sides: no
    contact, although the thighs' bones (not neighbours) are the nearest on its two sides."""
    shape = (SIZE, SIZE)
    skirt = capsule(shape, (80, 60), (80, 120), 30)
    fold = capsule(shape, (80, 75), (80, 112), 1.0)
    skeleton = Skeleton(("pelvis", "l_hip", "l_knee", "r_hip", "r_knee"), np.array([-1, 0, 1, 0, 3]))
    pose = np.array([[80, 62, 0], [68, 70, 0], [68, 118, 0], [92, 70, 0], [92, 118, 0]], float)
    drawing = ink_drawing(outline(skirt) | fold)
    assert stroke_contacts(drawing, skirt, pose, skeleton) == []
    # the fold carried through from waist to hem parts the skirt in two: the thighs touch along it
    drawing = ink_drawing(outline(skirt) | capsule(shape, (80, 20), (80, 155), 1.0))
    assert stroke_contacts(drawing, skirt, pose, skeleton)


def test_a_thick_crayon_outline_is_one_stroke_on_a_large_drawing(monkeypatch):
    """A photographed drawing 600 px high with an outline 14 px wide: the outline is one stroke, not two edges
    with a ring of body between them, so the forearm whose hand reaches the outline touches nothing. At the
    reference scale the ring's inside is a compartment of its own and the forearm, crossing it, holds it."""
    shape = (600, 600)
    body = capsule(shape, (300, 150), (300, 450), 150)
    inner = capsule(shape, (300, 150), (300, 450), 136)
    skeleton = Skeleton(("pelvis", "neck", "shoulder", "elbow", "hand"), np.array([-1, 0, 1, 2, 3]))
    pose = np.array([[300, 450, 0], [300, 150, 0], [230, 180, 0], [210, 300, 0], [152, 330, 0]], float)
    rng = np.random.default_rng(0)
    drawing = np.broadcast_to(np.float32(0.94), shape + (3,)).copy()
    drawing += rng.normal(0, 0.01, drawing.shape).astype(np.float32)
    drawing[body & ~inner] = (0.25, 0.2, 0.6)  # a purple crayon outline
    assert stroke_contacts(drawing, body, pose, skeleton) == []
    monkeypatch.setattr(contacts_mod, "scale_of", lambda character: 1.0)
    assert stroke_contacts(drawing, body, pose, skeleton)


def test_the_watercolour_forearm_parts_from_the_waist_along_the_whole_gap():
    """data_samples/watercolour, key0: the right forearm hangs 3-9 px off the shirt and skirt with only paper
    between. Where the gap is widest a sliver of it is a hole of the foreground that the mesh closes over; both
    must count as glued paper, or the contact breaks at the waist (y 111-117) and the forearm drags the skirt."""
    from ops.shotio.image_io import read_image, to_rgba
    from ops.shotio.load import load_shot

    shot = load_shot(SAMPLES / "watercolour")
    masks = build_masks(to_rgba(read_image(shot.keyframes[0])), shot.key_pose(0), shot.skeleton)
    spans = []
    for piece in masks.contacts:
        ys, xs = np.nonzero(piece)
        if xs.max() < 120:  # the right arm's side of the body (image left)
            spans.append((ys.min(), ys.max()))
    assert any(top <= 104 and bottom >= 135 for top, bottom in spans), spans


def test_gap_sides_in_the_gaps_box_equal_the_whole_images_transforms():
    """gap_sides computes one distance transform per bone in the box around the gap only: brute force over the
    whole image (as it was computed before) must give the same sides, bit for bit, for gaps in the middle, at
    the frame's edge and in several pieces."""
    rng = np.random.default_rng(7)
    shape = (120, 150)
    for trial in range(6):
        owned = rng.integers(-1, 5, size=shape)
        owned = cv2.resize(owned.astype(np.float32), (shape[1] // 6, shape[0] // 6), interpolation=cv2.INTER_NEAREST)
        owned = cv2.resize(owned, (shape[1], shape[0]), interpolation=cv2.INTER_NEAREST).astype(np.int64)
        gap = np.zeros(shape, bool)
        gap[40:52, 30:37] = True  # a strip
        gap[70:75, 90:120] = trial % 2 == 0  # a second piece, far from the first
        gap[0:6, 140:150] = trial >= 3  # one at the frame's corner
        owned[gap] = -1
        side = 1 + trial % 3
        reach = contacts_mod.ndimage.distance_transform_edt(gap) + side
        want = np.zeros((5,) + shape, bool)
        for bone in range(5):
            if (owned == bone).any():
                want[bone] = gap & (contacts_mod.ndimage.distance_transform_edt(owned != bone) <= reach)
        got = contacts_mod.gap_sides(gap, owned, side, 5)
        assert want.any() and np.array_equal(got, want)
    assert not contacts_mod.gap_sides(np.zeros(shape, bool), owned, 2, 5).any()


def test_the_lamps_arm_resting_on_the_base_is_cut_through_to_the_shades_junction():
    """data_samples/lamp, key0: the shade hangs over the base's end (a region with two T-junctions) and the arm
    above it rests on the base. The contact between arm and base stops AVOID_PX short of the region; carried on
    to the upper junction, it leaves no bridge of mesh there, which had dragged the base's end up with the shade
    as a web of stretched ink in key0's lane. Every junction is the end of one slit, never of two."""
    from ops.shotio.image_io import read_image, to_rgba
    from ops.shotio.load import load_shot

    shot = load_shot(SAMPLES / "lamp")
    pose = shot.key_pose(0)
    masks = build_masks(to_rgba(read_image(shot.keyframes[0])), pose, shot.skeleton, occlusion="hybrid")
    refined = refine_masks(masks, np.asarray(shot.t_junctions[0], float), pose, shot.skeleton,
                           other_pose=[shot.key_pose(1)])
    junctions = np.concatenate([B[j] for B, j in zip(refined.boundaries, refined.junctions)])
    assert len(junctions) == 2
    ends = np.array([s[e] for s in refined.slits for e in (0, -1)])
    for p in junctions:
        assert np.sum(np.linalg.norm(ends - p, axis=1) < 1e-6) == 1, (p, ends)


def test_a_drawing_on_a_larger_page_has_the_same_contacts():
    """Lengths grow with the character, not with its canvas: arm_cross's key1 drawn 1.6 times larger (scale
    1.25) reads the same contacts alone and padded with 120 px of its paper on every side."""
    from ops.shotio.load import load_shot

    shot = load_shot(SAMPLES / "arm_cross")
    drawing = cv2.imread(shot.keyframes[1])[..., ::-1].astype(np.float32) / 255.0
    drawing = cv2.resize(drawing, None, fx=1.6, fy=1.6, interpolation=cv2.INTER_LINEAR)
    pose = shot.key_pose(1) * [1.6, 1.6, 1.0]
    masks = build_masks(drawing, pose, shot.skeleton)
    body = masks.foreground & (masks.coverage >= 0.5)
    assert contacts_mod.scale_of(body) > 1.0
    alone = stroke_contacts(drawing, body, pose, shot.skeleton)
    pad = 120
    page = np.pad(drawing, ((pad, pad), (pad, pad), (0, 0)), mode="edge")  # the corners are paper
    padded = stroke_contacts(page, np.pad(body, pad), pose + [pad, pad, 0], shot.skeleton)
    assert alone and len(padded) == len(alone)
    np.testing.assert_array_equal(np.any(padded, axis=0)[pad:-pad, pad:-pad], np.any(alone, axis=0))
