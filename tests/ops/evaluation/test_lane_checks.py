"""Tests of ops.evaluation.lane_checks: the warnings for a lane that tears or misses the other key, at the bones
where it does."""
import numpy as np

from ops.evaluation.lane_checks import AGREE_DB, TORN_SHARE, agreement, agreement_warning, torn_shares, torn_warning
from ops.evaluation.metrics import psnr
from ops.types import DeformedSequence, Masks, Skeleton
from ops.warning_subject import parse

SKELETON = Skeleton(joints=("hip", "knee", "foot", "toe"), parents=np.array([-1, 0, 1, 2]))  # bones 0, 1, 2


def sequence(torn_boxes: list[tuple[int, int, int, int]], frame: int = 1, size: int = 64,
             visible: tuple[int, int, int, int] | None = None) -> DeformedSequence:
    """Three frames of a character covering the (size, size) image (or the box `visible`, (x0, y0, x1, y1));
    frame `frame` torn in the boxes, the others not."""
    T = 3
    images = np.zeros((T, size, size, 4), np.float32)
    x0, y0, x1, y1 = visible or (0, 0, size, size)
    images[:, y0:y1, x0:x1, 3] = 1.0
    distorted = np.zeros((T, size, size), bool)
    for x0, y0, x1, y1 in torn_boxes:
        distorted[frame, y0:y1, x0:x1] = True
    return DeformedSequence(times=np.linspace(0, 1, T), vertices=np.zeros((T, 3, 2)), images=images,
                            inpainted=np.zeros((T, size, size), bool), energies=np.zeros(T),
                            iterations=np.zeros(T, np.int64), distorted=distorted)


# in the frames: the thigh (hip-knee) along y = 10, the shin (knee-foot) down x = 60, the foot (foot-toe) along
# y = 60; at the key, the whole leg lies elsewhere, so the warning's place must come from the key's pose
FRAME_POSE = np.array([[0, 10, 0], [60, 10, 0], [60, 60, 0], [10, 60, 0]], float)
KEY_POSE = FRAME_POSE + [100, 200, 0]
POSES = np.stack([FRAME_POSE] * 3)


def test_a_frame_torn_past_the_share_is_warned_of_at_its_bone_in_the_keys_place():
    # a character drawn along the shin alone, torn over 30 of its 64 rows: 47 %, every torn pixel nearest the shin
    seq = sequence([(52, 20, 64, 50)], visible=(52, 0, 64, 64))
    assert torn_shares(seq)[1] > TORN_SHARE and torn_shares(seq)[0] == 0
    s = parse(torn_warning(seq, POSES, KEY_POSE, SKELETON, key=1))
    assert s is not None and s.kind == "bone" and s.names == ("knee-foot",)
    np.testing.assert_allclose(s.at, KEY_POSE[[1, 2], :2].mean(axis=0))
    assert "frame 1" in s.problem and "key1" in s.fix


def test_two_bones_sharing_the_tear_are_both_named():
    seq = sequence([(0, 0, 64, 20), (0, 44, 64, 64)])  # the thigh's band and the foot's: 62 % of the character
    s = parse(torn_warning(seq, POSES, KEY_POSE, SKELETON, key=0))
    assert s.kind == "bones" and set(s.names) == {"hip-knee", "foot-toe"}


def test_no_warning_at_or_below_the_share():
    seq = sequence([(0, 0, 64, int(64 * TORN_SHARE))])
    assert torn_shares(seq).max() <= TORN_SHARE
    assert torn_warning(seq, POSES, KEY_POSE, SKELETON, key=0) is None
    seq.distorted = None  # a sequence rendered without the mark
    assert torn_warning(seq, POSES, KEY_POSE, SKELETON, key=0) is None


def masks_of(colour: np.ndarray, coverage: np.ndarray) -> Masks:
    """A key's masks holding a drawing of `colour` (H, W, 3) under `coverage` (H, W) on grey paper."""
    paper = np.full(colour.shape, 0.9, np.float32)
    return Masks(foreground=coverage > 0, occlusion=[], front_bones=[], coverage=coverage.astype(np.float32),
                 colour=colour.astype(np.float32), paper=paper, source="manual", holes=np.zeros(coverage.shape, bool),
                 n_holes=0)


def test_agreement_is_the_psnr_against_the_drawing_the_masks_hold():
    rng = np.random.default_rng(3)
    coverage = np.zeros((64, 64), np.float32)
    coverage[10:54, 55:62] = 1.0  # the shin, drawn dark
    m = masks_of(rng.uniform(0, 0.3, (64, 64, 3)), coverage)
    drawing = coverage[..., None] * m.colour + (1 - coverage[..., None]) * m.paper
    lane = np.concatenate([m.colour, coverage[..., None]], axis=-1)  # the drawing's own character
    db, diff = agreement(lane, m)
    assert db > 60 and diff.max() < 1e-5
    moved = np.roll(lane, 5, axis=1)  # the shin drawn 5 px to the right
    db, diff = agreement(moved, m)
    got = moved[..., :3] * moved[..., 3:] + (1 - moved[..., 3:]) * m.paper
    assert abs(db - psnr(got, drawing)) < 1e-9 and diff[30, 62] > 0.3 and diff[30, 20] == 0


def test_a_lane_far_from_the_other_drawing_is_warned_of_at_the_bone_where_it_differs():
    diff = np.zeros((64, 64))
    diff[20:50, 56:64] = 1.0  # the difference lies along the shin (x = 60 at the other key's pose)
    s = parse(agreement_warning(AGREE_DB - 2, diff, FRAME_POSE, KEY_POSE, SKELETON, key=0, other=1))
    assert s.kind == "bone" and s.names == ("knee-foot",) and "19.0 dB from key1's drawing" in s.problem
    np.testing.assert_allclose(s.at, KEY_POSE[[1, 2], :2].mean(axis=0))  # at the lane's own key, where it is fixed
    assert "left/right mix-up" in s.fix
    assert agreement_warning(AGREE_DB, diff, FRAME_POSE, KEY_POSE, SKELETON, key=0, other=1) is None
