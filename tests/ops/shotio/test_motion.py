"""Motion across keys: one C1 curve per bone parameter, eased per segment, given poses exact."""
import numpy as np
import pytest

from ops.shotio.motion import catmull_rom, eased_clock, interpolate_motion, pose_from_parameters, pose_parameters

PARENTS = np.array([-1, 0, 1, 2])  # a chain: root, and three bones


def _chain(angles, lengths=(30.0, 25.0, 20.0), root=(100.0, 100.0), z=(0.0, -1.0, -1.0, -2.0)) -> np.ndarray:
    """(4, 3) pose of the chain with these relative bone angles (radians)."""
    out = np.zeros((4, 3))
    out[0, :2] = root
    world = 0.0
    for j, (a, n) in enumerate(zip(angles, lengths), start=1):
        world += a
        out[j, :2] = out[j - 1, :2] + n * np.array([np.cos(world), np.sin(world)])
    out[:, 2] = z
    return out


def test_parameters_round_trip_through_forward_kinematics():
    pose = _chain([0.3, -1.2, 2.5])
    np.testing.assert_allclose(pose_from_parameters(pose_parameters(pose[None], PARENTS)[0], PARENTS), pose,
                               atol=1e-9)


def test_angles_unwrap_along_the_shorter_arc():
    a, b = _chain([3.0, 0.0, 0.0]), _chain([-3.0, 0.0, 0.0])  # 0.28 rad apart across pi, not 6 rad
    p = pose_parameters(np.stack([a, b]), PARENTS)
    assert abs(p[1, 1] - p[0, 1]) == pytest.approx(2 * np.pi - 6.0)


def test_catmull_rom_interpolates_with_continuous_slope():
    knots = np.array([0.0, 3.0, 8.0, 9.0])
    values = np.array([[0.0], [2.0], [-1.0], [4.0]])
    curve = catmull_rom(knots, values)
    np.testing.assert_allclose(curve(knots), values, atol=1e-12)
    h = 1e-6
    for k in knots[1:-1]:  # left and right derivatives agree at every inner knot
        left = (curve(np.array([k])) - curve(np.array([k - h]))) / h
        right = (curve(np.array([k + h])) - curve(np.array([k]))) / h
        np.testing.assert_allclose(left, right, atol=1e-4)


def _angular_velocity(poses: np.ndarray) -> np.ndarray:
    """(F - 1, J) change of each joint's relative angle per frame."""
    return np.diff(pose_parameters(poses, PARENTS)[:, :4], axis=0)


def test_the_motion_has_no_kink_at_a_key():
    """Keys swinging the arm one way then back: per segment (v1) the velocity jumps at the middle key; the curve's
    largest jump there stays within 1.5x that of the neighbouring frames."""
    keys = np.stack([_chain([0.0, 0.2, 0.1]), _chain([0.6, 1.2, 0.5]), _chain([0.8, 0.4, 1.6])])
    poses = interpolate_motion(np.array([0.0, 8.0, 16.0]), keys, (0, 8, 16), ("linear", "linear"), PARENTS, 17)
    jump = np.abs(np.diff(_angular_velocity(poses), axis=0))  # (F - 2, J): jump[i] is at frame i + 1
    at_key = jump[8 - 1].max()
    around = max(jump[8 - 3].max(), jump[8 - 2].max(), jump[8].max(), jump[8 + 1].max())
    assert at_key <= 1.5 * around
    np.testing.assert_array_equal(poses[[0, 8, 16]], keys)


def test_ease_retimes_a_segment_without_moving_its_keys():
    clock = eased_clock(np.arange(9.0), np.array([0.0, 8.0]), 0.0, 8.0, "out")
    np.testing.assert_allclose(clock[[0, -1]], [0, 8])
    steps = np.diff(clock)
    assert steps[0] < 0.25 * steps[-1] and (steps > 0).all()  # slow out of the key, then at full speed
    back = eased_clock(np.arange(9.0), np.array([0.0, 8.0]), 0.0, 8.0, "in")
    np.testing.assert_allclose(np.diff(back), np.diff(clock)[::-1])  # slow in: the mirror image
    both = np.diff(eased_clock(np.arange(9.0), np.array([0.0, 8.0]), 0.0, 8.0, "in-out"))
    assert both[0] < both[4] > both[-1]
    np.testing.assert_array_equal(eased_clock(np.arange(9.0), np.array([0.0, 8.0]), 0.0, 8.0, "linear"),
                                  np.arange(9.0))


def test_eased_segment_keeps_a_given_pose_inside_it():
    knots = np.array([0.0, 4.0, 8.0])
    clock = eased_clock(np.arange(9.0), knots, 0.0, 8.0, "in-out")
    assert clock[4] == 4.0 and clock[0] == 0.0 and clock[8] == 8.0
    assert np.all(np.diff(clock) > 0)

