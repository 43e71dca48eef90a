"""The 3D occlusion generator: exact ray casts, the BVH reader, hidden lines, depth-buffer truth, held-out splits."""
from __future__ import annotations

import math

import numpy as np
import pytest

from data_samples.generator import occlusion3d as ds
from data_samples.generator.bodies3d import FAMILIES, HUMAN, Body, person_body
from data_samples.generator.bvh import canonical_frame, humanoid_joints, read_bvh
from data_samples.generator.looks3d import STYLE_FAMILIES, make_look3d
from data_samples.generator.render3d import SS, render
from data_samples.generator.solids import cast, ellipsoid, frame_along, grid, limb


def test_sphere_entry_and_exit_are_analytic():
    c, r = np.array([10.0, 12.0, 50.0]), 6.0
    xs, ys = grid(0, 0, 25, 25, 1.0)
    d2 = (xs - c[0]) ** 2 + (ys - c[1]) ** 2
    expect_in = np.where(d2 < r * r, c[2] - np.sqrt(np.maximum(r * r - d2, 0)), np.inf)
    for s in (ellipsoid(c, np.eye(3), (r, r, r), 0), limb(c, c, r, r, 0)):  # a zero-length limb is a sphere
        entry, leave = cast(s, xs, ys)
        inside = d2 < r * r - 1e-6
        assert np.array_equal(np.isfinite(entry), inside)
        np.testing.assert_allclose(entry[inside], expect_in[inside], atol=1e-6)
        np.testing.assert_allclose(leave[inside], 2 * c[2] - expect_in[inside], atol=1e-6)


def test_rotated_ellipsoid_hits_lie_on_its_surface():
    axes = frame_along(np.array([1.0, 1.0, 0.5]), np.array([0.0, 0.0, 1.0]))
    s = ellipsoid(np.array([20.0, 20.0, 30.0]), axes, (12.0, 6.0, 4.0), 0)
    xs, ys = grid(0, 0, 41, 41, 1.0)
    entry, leave = cast(s, xs, ys)
    hit = np.isfinite(entry)
    assert 100 < hit.sum() < 41 * 41
    for z in (entry, leave):
        p = np.stack([xs[hit], ys[hit], z[hit]], 1) - s.centre
        q = (p @ s.axes.T) / s.radii
        np.testing.assert_allclose((q ** 2).sum(1), 1.0, atol=1e-6)


def test_round_cone_matches_a_dense_sweep():
    """The limb casts the spheres swept along its axis: against a sweep 50x denser, entry within 1% of a radius."""
    c0, c1 = np.array([5.0, 5.0, 20.0]), np.array([30.0, 18.0, 40.0])
    s = limb(c0, c1, 5.0, 2.5, 0)
    xs, ys = grid(0, 0, 40, 30, 0.5)
    entry, _ = cast(s, xs, ys)
    best = np.full(xs.shape, np.inf)
    for t in np.linspace(0, 1, 2000):
        c, r = c0 + t * (c1 - c0), 5.0 + t * (2.5 - 5.0)
        d2 = (xs - c[0]) ** 2 + (ys - c[1]) ** 2
        best = np.where(d2 < r * r, np.minimum(best, c[2] - np.sqrt(np.maximum(r * r - d2, 0))), best)
    both = np.isfinite(best) & np.isfinite(entry)
    assert np.isfinite(entry).sum() >= 0.99 * np.isfinite(best).sum()
    assert np.abs(entry[both] - best[both]).max() < 0.05 * 2.5 + 0.02


def test_box_slab_test():
    s = ellipsoid(np.array([10.0, 10.0, 20.0]), np.eye(3), (4.0, 3.0, 2.0), 0, kind="box")
    xs, ys = grid(0, 0, 21, 21, 1.0)
    entry, leave = cast(s, xs, ys)
    inside = (np.abs(xs - 10) <= 4) & (np.abs(ys - 10) <= 3)  # the faces count as inside
    assert np.array_equal(np.isfinite(entry), inside)
    assert np.allclose(entry[inside], 18.0) and np.allclose(leave[inside], 22.0)


TINY_BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333
1 2 3 0 0 0 0 0 0
0 0 0 90 0 0 0 90 0
"""


def test_bvh_world_positions(tmp_path):
    path = tmp_path / "tiny.bvh"
    path.write_text(TINY_BVH)
    m = read_bvh(path)
    assert m.names == ["Hips", "Spine", "Spine_end"] and m.parents == [-1, 0, 1] and m.frames.shape == (2, 9)
    np.testing.assert_allclose(m.world_positions(0), [[1, 2, 3], [1, 12, 3], [1, 17, 3]], atol=1e-9)
    # frame 1: the root turns 90 deg about z (y -> -x), the spine another 90 deg about x (its child's y -> z)
    np.testing.assert_allclose(m.world_positions(1), [[0, 0, 0], [-10, 0, 0], [-10, 0, 5]], atol=1e-9)
    with pytest.raises(ValueError, match="malformed BVH"):
        bad = tmp_path / "bad.bvh"
        bad.write_text(TINY_BVH.replace("Frames: 2", "Frames: 9"))
        read_bvh(bad)


def humanoid_bvh() -> str:
    """A T-pose humanoid clip in Mixamo names, y up, facing +z, one frame (the arms down in frame 1)."""
    joints = [("Hips", None, (0, 0, 0)), ("Spine", "Hips", (0, 10, 0)), ("Neck", "Spine", (0, 20, 0)),
              ("Head", "Neck", (0, 5, 0)), ("RightArm", "Spine", (-8, 18, 0)), ("RightForeArm", "RightArm", (-12, 0, 0)),
              ("RightHand", "RightForeArm", (-10, 0, 0)), ("LeftArm", "Spine", (8, 18, 0)),
              ("LeftForeArm", "LeftArm", (12, 0, 0)), ("LeftHand", "LeftForeArm", (10, 0, 0)),
              ("RightUpLeg", "Hips", (-5, 0, 0)), ("RightLeg", "RightUpLeg", (0, -20, 0)),
              ("RightFoot", "RightLeg", (0, -20, 0)), ("LeftUpLeg", "Hips", (5, 0, 0)),
              ("LeftLeg", "LeftUpLeg", (0, -20, 0)), ("LeftFoot", "LeftLeg", (0, -20, 0))]
    children = {n: [c for c, p, _ in joints if p == n] for n, _, _ in joints}
    offsets = {n: o for n, _, o in joints}

    def block(n: str, depth: int) -> list[str]:
        pad = "  " * depth
        head = f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {n}"
        chans = "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation" if depth == 0 else \
            "CHANNELS 3 Zrotation Xrotation Yrotation"
        lines = [head, pad + "{", f"{pad}  OFFSET {' '.join(map(str, offsets[n]))}", f"{pad}  {chans}"]
        for c in children[n]:
            lines += block(c, depth + 1)
        return lines + [pad + "}"]
    order = []

    def walk(n: str) -> None:
        order.append(n)
        for c in children[n]:
            walk(c)
    walk("Hips")
    rest = [0.0] * (6 + 3 * (len(order) - 1))
    down = list(rest)
    for side, angle in (("LeftArm", -90.0), ("RightArm", 90.0)):  # about z: the arms hang down
        down[6 + 3 * (order.index(side) - 1)] = angle
    rows = [" ".join(map(str, r)) for r in (rest, down)]
    return "\n".join(["HIERARCHY"] + block("Hips", 0) + ["MOTION", "Frames: 2", "Frame Time: 0.0333"] + rows) + "\n"


def test_bvh_drives_the_generator_person_by_bone_direction(tmp_path):
    path = tmp_path / "t.bvh"
    path.write_text(humanoid_bvh())
    m = read_bvh(path)
    axes = canonical_frame(m)
    np.testing.assert_allclose(axes, np.eye(3), atol=1e-9)  # x = left, y = up, z = forward already
    j = humanoid_joints(m, 1, axes)
    assert j["left_hand"][1] < j["left_elbow"][1] < j["left_shoulder"][1]  # hanging down
    body = person_body(np.random.default_rng(0), "thin", m, 1)
    assert body.motion == "bvh"
    p = body.pose
    arm = p[HUMAN.index("left_elbow")] - p[HUMAN.index("left_shoulder")]
    assert arm[1] / np.linalg.norm(arm) < -0.99  # the generator's own arm points where the clip's does
    leg = p[HUMAN.index("right_knee")] - p[HUMAN.index("right_hip")]
    assert leg[1] / np.linalg.norm(leg) < -0.99


def two_spheres(near_z: float, far_z: float, fused: bool = False):
    """Two overlapping spheres on bones 0 and 1 (bone = child joint 1 and 2), 96 px: the near one at left."""
    r = 18.0
    gap = 14.0 if fused else 26.0
    a = ellipsoid(np.array([38.0, 48.0, near_z]), np.eye(3), (r, r, r), 1, "top", "a")
    b = ellipsoid(np.array([38.0 + gap, 48.0, far_z]), np.eye(3), (r, r, r), 2, "top", "b")
    return [a, b]


def ink_look(crease: bool = False):
    look = make_look3d("ink", np.random.default_rng(1))
    from dataclasses import replace
    return replace(look, fill="paper", line_width=2.0, width_var=0.0, breaks=0.0, crease=crease, wobble=0.0,
                   photo=False, blur=0.0, paper="white", marks=False)


def test_depth_buffer_truth_and_hidden_lines():
    """Two discs overlapping: the truth is their intersection, the nearer in front; the near sphere's outline is
    drawn across the far one, the far one's outline under the near one is hidden."""
    near = render(two_spheres(100.0, 160.0), [], (96, 96), ink_look(), 0)
    yy, xx = np.mgrid[0:96, 0:96]
    da = np.hypot(xx - 38, yy - 48)
    db = np.hypot(xx - 64, yy - 48)
    both = near.cover[1] & near.cover[2]
    expect = (da < 17) & (db < 17)
    assert expect.sum() > 100 and (both & expect).sum() == expect.sum()
    assert (both & ~((da < 20.5) & (db < 20.5))).sum() == 0
    assert (near.entry[1][expect] < near.entry[2][expect]).all()
    dark = near.rgb.mean(axis=2) < 128
    a_rim_over_b = (np.abs(da - 18) < 0.6) & (db < 14)  # the near outline, inside the far disc
    b_rim_under_a = (np.abs(db - 18) < 0.6) & (da < 14)  # the far outline, inside the near disc
    assert dark[a_rim_over_b].mean() > 0.9
    assert dark[b_rim_under_a].mean() < 0.05


def test_interpenetrating_bodies_meet_without_a_line_unless_creased():
    """Spheres at the same depth cross each other: no occluding contour where they meet, only a crease if the
    look draws creases."""
    spheres = two_spheres(100.0, 100.0, fused=True)
    yy, xx = np.mgrid[0:96, 0:96]
    seam = (np.abs(xx - 45) <= 1) & (np.abs(yy - 48) < 8)  # where the two surfaces meet (x = 38 + 14 / 2)
    plain = render(spheres, [], (96, 96), ink_look(crease=False), 0).rgb.mean(axis=2) < 128
    creased = render(spheres, [], (96, 96), ink_look(crease=True), 0).rgb.mean(axis=2) < 128
    assert plain[seam].mean() < 0.05 and creased[seam].mean() > 0.3


def test_held_out_families_never_train():
    idx = ds.train_indices(400)
    assert all(ds.sample_family(i) != ds.HELD_OUT_FAMILY and ds.sample_style(i) != ds.HELD_OUT_STYLE for i in idx)
    assert len(set(idx)) == 400
    for kind, test in (("body", lambda i: ds.sample_family(i) == ds.HELD_OUT_FAMILY
                        and ds.sample_style(i) != ds.HELD_OUT_STYLE),
                       ("style", lambda i: ds.sample_style(i) == ds.HELD_OUT_STYLE
                        and ds.sample_family(i) != ds.HELD_OUT_FAMILY),
                       ("seen", lambda i: ds.held_out(i) is None)):
        got = ds.held_out_indices(kind, 30)
        assert all(test(i) for i in got)
    combos = {(ds.sample_family(i), ds.sample_style(i)) for i in range(35)}
    assert len(combos) == len(FAMILIES) * len(STYLE_FAMILIES)
    assert ds.sample_seed("test", 0) == ds.TEST_SEED_BASE > ds.sample_seed("train", ds.TEST_SEED_BASE - 1)


@pytest.mark.parametrize("index", [0, 1, 2, 3, 4, 12])
def test_sample_truth_is_consistent(index):
    s = ds.make_sample3d("test", index)
    h, w = s.image.shape[:2]
    assert s.image.dtype == np.uint8 and ds.MIN_SIZE <= h <= ds.MAX_SIZE and ds.MIN_SIZE <= w <= ds.MAX_SIZE
    assert s.label == ds.sample_family(index) and s.style == ds.sample_style(index)
    assert s.pose.shape == (len(s.joints), 3) and len(s.parents) == len(s.joints) and s.parents.count(-1) == 1
    n_bones = len(s.joints) - 1
    fg = s.foreground >= 0.5
    union = np.zeros((h, w), bool)
    for m, p in zip(s.occlusion, s.pairs):
        assert m.sum() == p["pixels"] >= ds.MIN_OVERLAP_PX and not (m & ~fg).any()
        assert 0 <= p["front_bone"] < n_bones and 0 <= p["back_bone"] < n_bones and p["front_bone"] != p["back_bone"]
        assert 0.5 <= p["front_share"] <= 1.0
        union |= m
    np.testing.assert_array_equal(union, s.occlusion_union)
    assert not (fg[0].any() or fg[-1].any() or fg[:, 0].any() or fg[:, -1].any())
    assert 0.02 < fg.mean() < 0.8


def test_samples_are_deterministic():
    a, b = ds.make_sample3d("train", 5), ds.make_sample3d("train", 5)
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.pose, b.pose)
    assert a.pairs == b.pairs and a.view == b.view
    assert not np.array_equal(ds.make_sample3d("test", 5).pose, a.pose)


def test_the_animated_drawings_skeleton_carries_the_left_out_joints_bodies():
    """Without a head joint the head's bodies belong to the torso-neck bone, whose neck sits at the head's
    centre; without toes the feet belong to the shins."""
    body = person_body(np.random.default_rng(3), "round")
    project = lambda p: np.asarray(p, np.float64)  # noqa: E731
    joints, parents, pose, bone_of = ds.reduce_skeleton(body, body.pose, project, ad=True)
    assert "head" not in joints and "right_toe" not in joints and len(joints) == 16
    children = [c for c in range(len(parents)) if parents[c] >= 0]
    bone_name = lambda b: (joints[parents[children[b]]], joints[children[b]])  # noqa: E731
    assert bone_name(bone_of[HUMAN.index("head")]) == ("torso", "neck")
    assert bone_name(bone_of[HUMAN.index("right_toe")]) == ("right_knee", "right_foot")
    head = next(s for s in body.solids if s.name == "head")
    np.testing.assert_allclose(pose[joints.index("neck")], head.centre)
    full = ds.reduce_skeleton(body, body.pose, project, ad=False)
    assert len(full[0]) == len(body.joints)


def test_every_family_and_style_draws():
    rng = np.random.default_rng(0)
    for style in STYLE_FAMILIES:
        look = make_look3d(style, rng)
        assert look.family == style and look.line_width >= 0
    for fam in FAMILIES:
        s = ds.make_sample3d("train", 11, family=fam, style="flat")
        assert s.label == fam and s.image.std() > 5 and isinstance(s.view, str)
    assert isinstance(Body, type) and math.isfinite(SS)
