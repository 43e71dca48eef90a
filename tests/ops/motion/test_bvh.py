"""The BVH parser: analytic forward kinematics, channel order, namespaces, frame slices, one-line errors."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ops.errors import ShotError
from ops.motion.bvh import base_name, frame_slice, parse_bvh, parse_bvh_text

ARM = """HIERARCHY
ROOT mixamorig:Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT mixamorig:Arm
  {
    OFFSET 2 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT mixamorig:Hand
    {
      OFFSET 3 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 1 0 0
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.0333333
1 2 3 0 0 0 0 0 0 0 0 0
1 2 3 90 0 0 0 0 0 0 0 0
0 0 0 0 0 0 90 90 0 0 0 0
"""


def test_forward_kinematics_matches_rotations_applied_in_channel_order():
    bvh = parse_bvh_text(ARM)
    assert bvh.names == ("mixamorig:Hips", "mixamorig:Arm", "mixamorig:Hand") and bvh.frames == 3
    P = bvh.world_positions()
    assert np.allclose(P[0], [[1, 2, 3], [3, 2, 3], [6, 2, 3]])
    # root turned 90 degrees about z: the arm points along +y
    assert np.allclose(P[1], [[1, 2, 3], [1, 4, 3], [1, 7, 3]])
    # the arm's channels Z then X (intrinsic): R = Rz(90) Rx(90); the hand offset (3, 0, 0) maps to R @ (3, 0, 0)
    R = Rotation.from_euler("z", 90, degrees=True).as_matrix() @ Rotation.from_euler("x", 90, degrees=True).as_matrix()
    assert np.allclose(P[2, 2], [2, 0, 0] + R @ [3, 0, 0])
    other = Rotation.from_euler("x", 90, degrees=True).as_matrix() @ Rotation.from_euler("z", 90, degrees=True).as_matrix()
    assert not np.allclose(P[2, 2], [2, 0, 0] + other @ [3, 0, 0])  # the other order would put it elsewhere


def test_names_match_without_namespace_prefixes(tmp_path):
    f = tmp_path / "clip.bvh"
    f.write_text(ARM)
    bvh = parse_bvh(f)
    assert bvh.index("Hand") == 2 and bvh.index("other:Arm") == 1 and base_name("mixamorig:LeftArm") == "LeftArm"
    with pytest.raises(KeyError):
        bvh.index("Foot")


def test_frame_slices_follow_python_and_thin_fast_captures():
    assert frame_slice("0:10:2", 100, 1 / 30).tolist() == [0, 2, 4, 6, 8]
    assert frame_slice("5:", 8, 1 / 30).tolist() == [5, 6, 7]
    assert frame_slice(None, 12, 1 / 120).tolist() == [0, 4, 8]  # 120 fps thinned to 30
    assert frame_slice(None, 5, 1 / 24).tolist() == [0, 1, 2, 3, 4]
    for bad in ("0:10:0", "a:b", "0:1:2:3", "50:60"):
        with pytest.raises(ShotError) as e:
            frame_slice(bad, 20, 1 / 30)
        assert e.value.field == "--bvh-frames"


@pytest.mark.parametrize("text, field", [
    ("no hierarchy here", "HIERARCHY"),
    (ARM.replace("Frames: 3", "Frames: 5"), "MOTION"),
    (ARM.replace("1 2 3 90 0 0 0 0 0 0 0 0", "1 2 3 90 0 0"), "MOTION"),
    (ARM.replace("Zrotation Xrotation Yrotation\n      End", "Zrotation Wrotation Yrotation\n      End"), "HIERARCHY"),
    (ARM.replace("  }\n}\nMOTION", "  }\nMOTION"), "HIERARCHY"),
    (ARM.replace("0 0 0 0 0 0 90 90", "0 0 0 0 0 0 nan 90"), "MOTION"),
])
def test_malformed_files_are_one_shot_error_naming_the_section(text, field, tmp_path):
    f = tmp_path / "bad.bvh"
    f.write_text(text)
    with pytest.raises(ShotError) as e:
        parse_bvh(f)
    assert e.value.field == field and str(f) in str(e.value) and "\n" not in str(e.value)
