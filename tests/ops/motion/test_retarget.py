"""Retargeting a BVH clip the AnimatedDrawings way: projected bone angles, depth drivers, facing and up axis."""
import numpy as np
import pytest

from ops.errors import ShotError
from ops.motion.animated_drawings import read_retarget, read_yaml
from ops.motion.bvh import parse_bvh_text
from ops.motion.retarget import retarget
from ops.skeleton.templates import HUMANOID

# name, parent, offset: a Y-up actor facing +Z (its right is -X), arms out to the sides
ACTOR = [("Hips", None, (0, 0, 0)), ("Spine", "Hips", (0, 10, 0)), ("Neck", "Spine", (0, 10, 0)),
         ("Head", "Neck", (0, 5, 0)),
         ("RightArm", "Spine", (-4, 8, 0)), ("RightForeArm", "RightArm", (-6, 0, 0)), ("RightHand", "RightForeArm", (-5, 0, 0)),
         ("LeftArm", "Spine", (4, 8, 0)), ("LeftForeArm", "LeftArm", (6, 0, 0)), ("LeftHand", "LeftForeArm", (5, 0, 0)),
         ("RightUpLeg", "Hips", (-2, 0, 0)), ("RightLeg", "RightUpLeg", (0, -9, 0)), ("RightFoot", "RightLeg", (0, -9, 0)),
         ("LeftUpLeg", "Hips", (2, 0, 0)), ("LeftLeg", "LeftUpLeg", (0, -9, 0)), ("LeftFoot", "LeftLeg", (0, -9, 0))]

RETARGET = """
char_starting_location: [0.0, 0.0, -0.5]
bvh_projection_bodypart_groups:
- {name: Upper Limbs, method: frontal, bvh_joint_names: [RightArm, RightForeArm, RightHand, LeftArm, LeftForeArm, LeftHand]}
- {name: Lower Limbs, method: frontal, bvh_joint_names: [RightUpLeg, RightLeg, RightFoot, LeftUpLeg, LeftLeg, LeftFoot]}
- {name: Trunk, method: frontal, bvh_joint_names: [Hips, Spine, Neck, Head]}
char_bodypart_groups:
- {bvh_depth_drivers: [Hips], char_joints: [right_shoulder, left_shoulder, right_hip, left_hip, hip, torso, neck]}
- {bvh_depth_drivers: [LeftHand], char_joints: [left_elbow, left_hand]}
- {bvh_depth_drivers: [RightHand], char_joints: [right_elbow, right_hand]}
- {bvh_depth_drivers: [LeftFoot], char_joints: [left_knee, left_foot]}
- {bvh_depth_drivers: [RightFoot], char_joints: [right_knee, right_foot]}
char_bvh_root_offset:
  bvh_projection_bodypart_group_for_offset: Lower Limbs
  bvh_joints: [[RightFoot, RightLeg, RightUpLeg], [LeftFoot, LeftLeg, LeftUpLeg]]
  char_joints: [[left_foot, left_knee, left_hip], [right_foot, right_knee, right_hip]]
char_joint_bvh_joints_mapping:
  torso: !!python/tuple [Hips, Spine]
  neck: !!python/tuple [Hips, Head]
  right_elbow: !!python/tuple [RightArm, RightForeArm]
  right_hand: !!python/tuple [RightForeArm, RightHand]
  left_elbow: !!python/tuple [LeftArm, LeftForeArm]
  left_hand: !!python/tuple [LeftForeArm, LeftHand]
  right_knee: !!python/tuple [RightUpLeg, RightLeg]
  right_foot: !!python/tuple [RightLeg, RightFoot]
  left_knee: !!python/tuple [LeftUpLeg, LeftLeg]
  left_foot: !!python/tuple [LeftLeg, LeftFoot]
char_runtime_checks:
- [above, neck, right_shoulder, left_shoulder]
"""


def bvh_text(frames: list[dict[str, tuple[float, float, float]]], root_xyz=None, actor=ACTOR) -> str:
    """BVH text of the actor; frames: per frame {joint: (x, y, z) degrees}, channels Z X Y on every joint."""
    kids = {n: [c for c, p, _ in actor if p == n] for n, _, _ in actor}
    offset = {n: o for n, _, o in actor}
    lines = ["HIERARCHY"]

    def block(n, depth):
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {n}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {' '.join(map(str, offset[n]))}")
        pos = "Xposition Yposition Zposition " if depth == 0 else ""
        lines.append(f"{pad}  CHANNELS {6 if depth == 0 else 3} {pos}Zrotation Xrotation Yrotation")
        for c in kids[n]:
            block(c, depth + 1)
        if not kids[n]:
            lines.extend([pad + "  End Site", pad + "  {", pad + "    OFFSET 0 1 0", pad + "  }"])
        lines.append(pad + "}")

    block(actor[0][0], 0)
    lines += ["MOTION", f"Frames: {len(frames)}", "Frame Time: 0.0333333"]
    order = []

    def walk(n):
        order.append(n)
        for c in kids[n]:
            walk(c)
    walk(actor[0][0])
    for f, rot in enumerate(frames):
        vals = list(root_xyz[f]) if root_xyz is not None else [0.0, 18.0, 0.0]
        for n in order:
            x, y, z = rot.get(n, (0.0, 0.0, 0.0))
            vals += [z, x, y]
        lines.append(" ".join(f"{v:.6f}" for v in vals))
    return "\n".join(lines) + "\n"


KEY = np.c_[HUMANOID.positions * 300, np.zeros(len(HUMANOID.joints))]
PARENTS = np.asarray(HUMANOID.parents)


@pytest.fixture
def config(tmp_path):
    f = tmp_path / "retarget.yaml"
    f.write_text(RETARGET)
    return read_retarget(f)


def clip_of(frames, config, root_xyz=None):
    bvh = parse_bvh_text(bvh_text(frames, root_xyz))
    return retarget(bvh, "clip.bvh", config, np.arange(bvh.frames), HUMANOID.joints, PARENTS, KEY)


def test_a_forearm_turning_in_the_frontal_plane_turns_the_drawn_bone_by_the_same_angle(config):
    theta = np.linspace(0, 150, 6)
    clip = clip_of([{"RightForeArm": (0, 0, t)} for t in theta], config)
    got = clip.angles[HUMANOID.joints.index("right_hand")]
    # the forearm points to the actor's right (the image's left, angle pi); a turn about the forward axis by
    # theta lifts the hand: in image axes (y down) the bone's angle is pi - theta
    want = np.pi - np.radians(theta)
    assert np.allclose(np.cos(got), np.cos(want), atol=1e-9) and np.allclose(np.sin(got), np.sin(want), atol=1e-9)
    assert np.all(np.abs(np.diff(got)) < np.pi)  # unwrapped


def test_a_hand_swung_toward_the_viewer_is_nearer_than_the_body(config):
    clip = clip_of([{"RightForeArm": (0, 90, 0)}, {"RightForeArm": (0, -90, 0)}], config)
    hand, torso = HUMANOID.joints.index("right_hand"), HUMANOID.joints.index("torso")
    assert clip.depth[0, hand] < clip.depth[0, torso] < clip.depth[1, hand]
    assert clip.depth[0, torso] == clip.depth[0, HUMANOID.joints.index("root")]  # root takes its group's neighbour


def test_facing_and_up_axis_do_not_change_the_result(config):
    """The actor turned about its up axis, or the whole file Z-up: the same 2D motion (per-frame facing)."""
    rots = [{"RightForeArm": (0, 0, 40.0 * f), "LeftArm": (0, 20.0 * f, 10), "RightLeg": (30, 0, 0)} for f in range(4)]
    base = clip_of(rots, config)
    turned = clip_of([{**r, "Hips": (0, 73, 0)} for r in rots], config)
    z_up = clip_of([{**r, "Hips": (90, 0, 0)} for r in rots], config,
                   root_xyz=[(0.0, 0.0, 18.0)] * 4)
    for other in (turned, z_up):
        for j, a in base.angles.items():
            assert np.allclose(np.cos(other.angles[j]), np.cos(a), atol=1e-9), HUMANOID.joints[j]
            assert np.allclose(np.sin(other.angles[j]), np.sin(a), atol=1e-9), HUMANOID.joints[j]
        assert np.allclose(other.depth, base.depth, atol=1e-6)


def test_the_root_moves_by_the_clip_scaled_to_the_characters_legs(config):
    root_xyz = [(0.0, 18.0, 0.0), (-3.0, 18.0, 0.0), (-3.0, 20.0, 0.0)]  # a step to the actor's right, then up
    clip = clip_of([{}] * 3, config, root_xyz)
    key = KEY[:, :2]
    J = HUMANOID.joints
    leg = sum(np.linalg.norm(key[J.index(a)] - key[J.index(b)]) for a, b in
              [("left_foot", "left_knee"), ("left_knee", "left_hip"), ("right_foot", "right_knee"), ("right_knee", "right_hip")])
    scale = leg / 36.0  # the actor's legs: 2 x (9 + 9) units
    assert np.allclose(clip.root[1] - clip.root[0], [-3 * scale, 0], atol=1e-9)  # its right: the image's left
    assert np.allclose(clip.root[2] - clip.root[1], [0, -2 * scale], atol=1e-9)  # up: the image's -y


def test_names_the_clip_or_the_skeleton_lacks_are_one_line_each(config, tmp_path):
    bvh = parse_bvh_text(bvh_text([{}], actor=[a for a in ACTOR if a[0] != "LeftHand"]))
    with pytest.raises(ShotError) as e:
        retarget(bvh, tmp_path / "clip.bvh", config, np.arange(1), HUMANOID.joints, PARENTS, KEY)
    assert "clip.bvh" in str(e.value) and "'LeftHand'" in str(e.value)
    bvh = parse_bvh_text(bvh_text([{}]))
    joints = tuple("l_hand" if n == "left_hand" else n for n in HUMANOID.joints)
    with pytest.raises(ShotError) as e:
        retarget(bvh, "clip.bvh", config, np.arange(1), joints, PARENTS, KEY)
    assert "retarget.yaml" in str(e.value) and "'left_hand'" in str(e.value) and "\n" not in str(e.value)


def test_yaml_allows_python_tuples_and_no_other_python_tag(tmp_path):
    f = tmp_path / "a.yaml"
    f.write_text("pair: !!python/tuple [a, b]\n")
    assert read_yaml(f, "config") == {"pair": ("a", "b")}
    f.write_text('x: !!python/object/apply:os.system ["echo unsafe"]\n')
    with pytest.raises(ShotError) as e:
        read_yaml(f, "config")
    assert "YAML" in str(e.value)


def test_bad_projection_method_is_named(tmp_path):
    f = tmp_path / "r.yaml"
    f.write_text(RETARGET.replace("method: frontal, bvh_joint_names: [Hips", "method: orthographic, bvh_joint_names: [Hips"))
    with pytest.raises(ShotError) as e:
        read_retarget(f)
    assert e.value.field == "bvh_projection_bodypart_groups[2].method"


def test_numbered_copies_of_a_joint_each_move_as_the_joint_does(config):
    """A six-armed character's right_shoulder1..2 (AnimatedDrawings' char5): a config for one arm drives each copy
    as it drives the arm, scales the clip by one leg, and says so."""
    arm = ("right_shoulder", "right_elbow", "right_hand")
    J = list(HUMANOID.joints)
    joints = tuple(f"{n}1" if n in arm else n for n in J) + tuple(f"{n}2" for n in arm)
    parents = list(PARENTS) + [int(PARENTS[J.index("right_shoulder")])] + [len(J) + i for i in range(2)]
    key = np.vstack([KEY, KEY[[J.index(n) for n in arm]] + [0.0, 20.0, 0.0]])
    rots = [{"RightForeArm": (0, 20.0 * f, 30.0 * f), "RightArm": (0, 0, -15.0 * f)} for f in range(4)]
    bvh = parse_bvh_text(bvh_text(rots, [(0.0, 18.0, 0.0), (-2.0, 18.0, 0.0), (-2.0, 19.0, 0.0), (0.0, 18.0, 0.0)]))
    one = retarget(bvh, "clip.bvh", config, np.arange(4), HUMANOID.joints, PARENTS, KEY)
    six = retarget(bvh, "clip.bvh", config, np.arange(4), joints, np.asarray(parents), key)
    for n in ("right_elbow", "right_hand"):
        for copy in (f"{n}1", f"{n}2"):
            assert np.array_equal(six.angles[joints.index(copy)], one.angles[J.index(n)]), copy
    for n in arm:
        assert np.array_equal(six.depth[:, joints.index(f"{n}2")], one.depth[:, J.index(n)]), n
    assert np.array_equal(six.root, one.root)  # the leg chains are unchanged: the same scale
    assert [w for w in six.warnings if "numbered copies" in w] == [
        f"retarget.yaml: {n} drives its numbered copies {n}1, {n}2" for n in ("right_shoulder", "right_elbow", "right_hand")]


def test_numbered_copies_of_a_leg_scale_the_clip_by_the_first(config):
    """Numbered legs: the scale is one leg's (the first copy's), not the sum over copies."""
    leg = ("right_hip", "right_knee", "right_foot")
    J = list(HUMANOID.joints)
    joints = tuple(f"{n}1" if n in leg else n for n in J) + tuple(f"{n}2" for n in leg)
    parents = list(PARENTS) + [int(PARENTS[J.index("right_hip")])] + [len(J) + i for i in range(2)]
    key = np.vstack([KEY, KEY[[J.index(n) for n in leg]] * [1.0, 2.0, 1.0]])  # the second leg twice as long
    bvh = parse_bvh_text(bvh_text([{}] * 2, [(0.0, 18.0, 0.0), (-3.0, 18.0, 0.0)]))
    one = retarget(bvh, "clip.bvh", config, np.arange(2), HUMANOID.joints, PARENTS, KEY)
    legs = retarget(bvh, "clip.bvh", config, np.arange(2), joints, np.asarray(parents), key)
    assert np.allclose(legs.root, one.root, atol=1e-12)
