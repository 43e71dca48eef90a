"""Slits from T-junctions (ops.segmentation.slits.junction_slits): out through the corner's paper, only between
parts that are not joined."""
import cv2
import numpy as np
import pytest

from ops.geometry.polygon import project_to_polyline
from ops.segmentation.slits import MAX_INK_PX, junction_slits, parting_slits
from ops.types import Skeleton

SIZE = 80
CORNERS = np.array([[30.0, 33.0], [44.0, 33.0], [44.0, 47.0], [30.0, 47.0]])  # the crossing square


def crossing(between: int):
    """A horizontal bar (in front) across a vertical one (behind): coverage (1 on the bars, 0 on paper), the
    mesh domain (the bars' union grown by 3 px, as the mesh's margin), the crossing square as the region with
    its four corners as T-junctions, and a chain skeleton whose first bone is the vertical bar and whose last
    is the horizontal one, `between` bones apart (they run off the picture, like a curled tail; 0: the two
    share a joint)."""
    cov = np.zeros((SIZE, SIZE), np.float32)
    cov[10:71, 30:45] = 1.0  # vertical bar, behind
    cov[33:48, 10:71] = 1.0  # horizontal bar, in front
    grown = cv2.dilate((cov > 0).astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7)))
    contours, _ = cv2.findContours(grown, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    domain = [contours[0].reshape(-1, 2).astype(np.float64)]
    far = [[37.0 + 30.0 * i, -40.0] for i in range(1, between)]
    joints = [[37.0, 70.0], [37.0, 10.0]] + (far + [[70.0, 40.0], [10.0, 40.0]] if between else [[10.0, 40.0]])
    pose = np.array([[x, y, 0.0] for x, y in joints])
    pose[-2:, 2] = -1.0  # the horizontal bar nearer the viewer
    skeleton = Skeleton(joints=tuple(f"j{i}" for i in range(len(pose))), parents=np.arange(-1, len(pose) - 1))
    front = [np.array([len(skeleton.bones) - 1])]
    apart = pose.copy()
    apart[-2:, :2] += [0.0, 90.0]  # the other keyframe: the horizontal bar well below the vertical one
    region = np.zeros((SIZE, SIZE), bool)
    region[33:48, 30:45] = True  # the crossing square's pixels
    return cov, domain, [CORNERS], [np.arange(4)], front, region, pose, skeleton, apart


def test_slits_leave_each_junction_through_the_corner_paper():
    cov, domain, bounds, juncs, front, region, pose, skeleton, apart = crossing(between=3)
    slits = junction_slits(bounds, juncs, front, region, domain, cov, pose, skeleton, apart)
    assert len(slits) == 4
    starts = np.array([s[0] for s in slits])
    assert np.allclose(np.sort(starts, axis=0), np.sort(CORNERS, axis=0))
    for s in slits:
        _, d = project_to_polyline(s[-1][None], domain[0])
        assert d[0] < 1e-6  # ends on the mesh's outline
        # it runs into the concave corner's paper (diagonally away from the square), not along either bar
        corner = s[0]
        out = np.sign(corner - CORNERS.mean(axis=0))
        step = s[-1] - corner
        assert (np.sign(step) == out).all()
        ts = np.linspace(0, 1, 50)[:, None]
        pts = np.vstack([a + ts * (b - a) for a, b in zip(s[:-1], s[1:])])
        inked = cov[np.round(pts[:, 1]).astype(int).clip(0, SIZE - 1), np.round(pts[:, 0]).astype(int).clip(0, SIZE - 1)]
        length = np.linalg.norm(np.diff(s, axis=0), axis=1).sum()
        assert inked.mean() * length <= MAX_INK_PX + 1.0


@pytest.mark.parametrize("between", [0, 1])
def test_no_slit_between_joined_parts(between):
    """Bars whose bones share a joint (0), or a neighbouring bone (1: an upper arm under a sleeve's shoulder),
    are one body at the junction: no slit."""
    cov, domain, bounds, juncs, front, region, pose, skeleton, apart = crossing(between=between)
    assert junction_slits(bounds, juncs, front, region, domain, cov, pose, skeleton, apart) == []


def test_no_slit_where_the_way_out_crosses_a_fill():
    """A junction deep inside the character (no paper within reach) gets no slit."""
    cov, domain, bounds, juncs, front, region, pose, skeleton, apart = crossing(between=3)
    cov[:] = 1.0
    full = [np.array([[0.0, 0.0], [SIZE - 1.0, 0.0], [SIZE - 1.0, SIZE - 1.0], [0.0, SIZE - 1.0]])]
    assert junction_slits(bounds, juncs, front, region, full, cov, pose, skeleton, apart) == []


def test_no_slit_where_the_part_stays_on_the_body():
    """A part that the other keyframe leaves on the body it crosses (moved along it by less than SEPARATE_PX)
    stays sewn at its junctions."""
    cov, domain, bounds, juncs, front, region, pose, skeleton, _ = crossing(between=3)
    along = pose.copy()
    along[-2:, :2] += [0.0, 8.0]  # slid 8 px down the vertical bar: still across it
    assert junction_slits(bounds, juncs, front, region, domain, cov, pose, skeleton, along) == []
    assert junction_slits(bounds, juncs, front, region, domain, cov, pose, skeleton, pose) == []


def test_a_junction_slit_runs_out_along_a_contact_where_the_bodies_touch():
    """Beyond the junction the part and the body it crosses touch (two feet side by side below crossing shins):
    the corner holds no paper, and every way out crosses more character than the stroke at the junction. Along
    their contact, where the template parts them anyway, the junction is slit out to the outline; without it,
    not."""
    cov, _, bounds, juncs, front, region, pose, skeleton, apart = crossing(between=3)
    cov[47:55, 44:53] = 1.0  # the lower right corner filled: the two bodies touch there
    grown = cv2.dilate((cov > 0).astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7)))
    contours, _ = cv2.findContours(grown, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    domain = [contours[0].reshape(-1, 2).astype(np.float64)]
    contact = np.zeros((SIZE, SIZE), bool)
    for i in range(9):  # their shared stroke, from the junction out across the filled corner
        contact[47 + i, 44 + i] = True
    corner = CORNERS[2]  # (44, 47)
    without = junction_slits(bounds, juncs, front, region, domain, cov, pose, skeleton, apart)
    assert not any(np.allclose(s[0], corner) for s in without)
    along = junction_slits(bounds, juncs, front, region, domain, cov, pose, skeleton, apart, contact)
    slit = [s for s in along if np.allclose(s[0], corner)]
    assert len(slit) == 1 and len(along) == len(without) + 1
    _, d = project_to_polyline(slit[0][-1][None], domain[0])
    assert d[0] < 1e-6  # ends on the mesh's outline
    assert (slit[0][-1] > corner + 5).all()  # out through the filled corner, down and to the right


def test_a_junction_a_contacts_slit_already_leaves_gets_no_second_slit():
    """Where a contact's slit was carried on to a T-junction (slits.slit_of), that slit is the junction's way out:
    a second one beside it would leave a sliver of mesh between the two."""
    cov, domain, bounds, juncs, front, region, pose, skeleton, apart = crossing(between=3)
    taken = CORNERS[[0, 2]]
    slits = junction_slits(bounds, juncs, front, region, domain, cov, pose, skeleton, apart, cut=taken)
    starts = np.array([s[0] for s in slits])
    assert len(slits) == 2
    assert np.allclose(np.sort(starts, axis=0), np.sort(CORNERS[[1, 3]], axis=0))


def arm_along_torso():
    """A torso (cols 20-40) with an arm hanging against its right side (cols 41-50, rows 20-60), one piece of
    character; the mesh domain (the union grown by 3 px); a contact's slit down the seam that stops inside the
    mesh at both ends (rows 30-50, 13 px from the outline); a skeleton root - neck up the torso, then shoulder,
    elbow, hand down the arm."""
    cov = np.zeros((SIZE, SIZE), np.float32)
    cov[10:71, 20:41] = 1.0
    cov[20:61, 41:51] = 1.0
    grown = cv2.dilate((cov > 0).astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7)))
    contours, _ = cv2.findContours(grown, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    domain = [contours[0].reshape(-1, 2).astype(np.float64)]
    slit = np.array([[40.5, 30.0 + 3.0 * i] for i in range(7)] + [[40.5, 50.0]])
    pose = np.array([[30.0, 70.0, 0.0], [30.0, 10.0, 0.0], [45.0, 12.0, 0.0], [45.0, 35.0, 0.0], [45.0, 58.0, 0.0]])
    skeleton = Skeleton(joints=("root", "neck", "shoulder", "elbow", "hand"), parents=np.array([-1, 0, 1, 2, 3]))
    return cov, domain, slit, pose, skeleton


def test_a_contacts_slit_is_carried_to_the_outline_where_the_other_key_parts_the_bodies():
    """The forearm lifted off the torso at the other key: the slit's lower end (beside the forearm, which parts)
    goes on to the outline, so the arm is a flap; its upper end (beside the upper arm, which stays) does not. A
    forearm that stays along the torso keeps the slit as it is."""
    cov, domain, slit, pose, skeleton = arm_along_torso()
    raised = pose.copy()
    raised[4, :2] = [68.0, 35.0]  # the hand out to the side: the forearm level
    regions = np.zeros((SIZE, SIZE), bool)
    [out] = parting_slits([slit], regions, domain, cov, pose, skeleton, raised)
    assert np.allclose(out[: len(slit)], slit)  # the upper end stays where it was
    _, d = project_to_polyline(out[-1][None], domain[0])
    assert d[0] < 1e-6 and len(out) > len(slit)  # the lower end reaches the outline
    way = out[len(slit):]
    assert out[-1][1] > 60.0  # on down the seam to the outline at the arm's foot, not across the arm
    assert np.all(np.abs(way[way[:, 1] <= 60.0, 0] - 40.5) < 2.0)
    [kept] = parting_slits([slit], regions, domain, cov, pose, skeleton, pose)
    assert np.array_equal(kept, slit)
    nudged = pose.copy()
    nudged[4, :2] += [3.0, 0.0]  # the hand a few pixels off: less than SEPARATE_PX
    [kept] = parting_slits([slit], regions, domain, cov, pose, skeleton, nudged)
    assert np.array_equal(kept, slit)


def test_a_parting_slit_never_cuts_a_piece_off_nor_meets_another_slits_end():
    """Both ends part at the other key (the whole arm swung off the torso): only the end that parts more is
    carried out, since with both on the outline the slit would cut the arm off the mesh. An end whose way out
    lands on another slit's end stays (the two would close a loop)."""
    cov, domain, slit, pose, skeleton = arm_along_torso()
    swung = pose.copy()
    swung[3:, :2] = [[68.0, 12.0], [91.0, 12.0]]  # the upper arm level, the forearm on out
    regions = np.zeros((SIZE, SIZE), bool)
    [out] = parting_slits([slit], regions, domain, cov, pose, skeleton, swung)
    on = [project_to_polyline(out[e][None], domain[0])[1][0] < 1e-6 for e in (0, -1)]
    assert sum(on) == 1
    raised = pose.copy()
    raised[4, :2] = [68.0, 35.0]
    [alone] = parting_slits([slit], regions, domain, cov, pose, skeleton, raised)
    other = np.array([alone[-1] + [8.0, 0.0], alone[-1] + [1.0, 0.5]])  # another slit ending where that way lands
    out, kept_other = parting_slits([slit, other], regions, domain, cov, pose, skeleton, raised)
    assert np.array_equal(out, slit) and np.array_equal(kept_other, other)
