"""The fit of a clip to drawn key poses: keys met exactly, the clip's own motion kept between them."""
import numpy as np

from ops.motion.clip import Clip
from ops.motion.fit import bone_geometry, fit_clip, wrap

# root, a spine of two bones, an arm of two bones on the spine's top, a leg of two off the root
PARENTS = np.array([-1, 0, 1, 2, 3, 0, 5])


def random_pose(rng, J=7):
    pose = np.zeros((J, 3))
    pose[0, :2] = rng.uniform(50, 150, 2)
    for j in range(1, J):
        a, r = rng.uniform(-np.pi, np.pi), rng.uniform(10, 40)
        pose[j, :2] = pose[PARENTS[j], :2] + r * np.array([np.cos(a), np.sin(a)])
    pose[:, 2] = rng.normal(0, 1, J)
    return pose


def random_clip(rng, F=20, driven=(1, 2, 3, 4), with_depth=True):
    t = np.arange(F)
    angles = {j: rng.uniform(-3, 3) + np.cumsum(rng.normal(0, 0.3, F)) for j in driven}
    return Clip(root=np.cumsum(rng.normal(0, 2, (F, 2)), axis=0), angles=angles,
                scales={4: 1 + 0.2 * np.sin(t / 3.0)}, depth=rng.normal(0, 1, (F, 7)) if with_depth else None)


def test_every_key_pose_is_met_exactly_by_the_forward_kinematics():
    rng = np.random.default_rng(0)
    for with_depth in (True, False):
        keys = np.stack([random_pose(rng) for _ in range(3)])
        kf = np.array([0, 7, 19])
        poses = fit_clip(random_clip(rng, with_depth=with_depth), PARENTS, kf, keys)
        assert poses.shape == (20, 7, 3)
        assert np.abs(poses[kf] - keys).max() < 1e-9


def test_with_one_key_driven_bones_turn_exactly_as_the_clip_turns():
    rng = np.random.default_rng(1)
    key = random_pose(rng)
    clip = random_clip(rng)
    poses = fit_clip(clip, PARENTS, np.array([0]), key[None])
    for j, theta in clip.angles.items():
        got = np.array([bone_geometry(p, PARENTS)[0][j] for p in poses])
        assert np.allclose(wrap(got - got[0] - (theta - theta[0])), 0, atol=1e-9)
    # undriven bones (5, 6) keep their drawn length; the scaled one follows the clip's factor
    lengths = np.array([bone_geometry(p, PARENTS)[1] for p in poses])
    assert np.allclose(lengths[:, 5:], lengths[0, 5:])
    assert np.allclose(lengths[:, 4] / lengths[0, 4], clip.scales[4] / clip.scales[4][0])
    # the root follows the clip's path from the drawn root
    assert np.allclose(poses[:, 0, :2] - key[0, :2], clip.root - clip.root[0])


def test_an_undriven_bone_rides_its_parent_bone():
    rng = np.random.default_rng(2)
    key = random_pose(rng)
    clip = random_clip(rng, driven=(1, 2, 3))  # bone 4 (the forearm) is not driven
    poses = fit_clip(clip, PARENTS, np.array([0]), key[None])
    rel = [wrap(bone_geometry(p, PARENTS)[0][4] - bone_geometry(p, PARENTS)[0][3]) for p in poses]
    assert np.allclose(rel, rel[0], atol=1e-9)


def test_offsets_blend_linearly_between_keys():
    """A clip that stands still between two different key poses: the bone angle moves evenly from one to the other."""
    rng = np.random.default_rng(3)
    a, b = random_pose(rng), random_pose(rng)
    F = 11
    clip = Clip(root=np.zeros((F, 2)), angles={j: np.zeros(F) for j in range(1, 7)})
    poses = fit_clip(clip, PARENTS, np.array([0, 10]), np.stack([a, b]))
    ang = np.array([bone_geometry(p, PARENTS)[0][3] for p in poses])
    step = wrap(np.diff(ang))
    assert np.allclose(step, step[0], atol=1e-9)
    assert np.allclose(poses[5, 0, :2], 0.5 * (a[0, :2] + b[0, :2]))
