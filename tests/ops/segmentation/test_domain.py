"""The meshed domain: every pixel with coverage inside, holes left open, one outline per component."""
from pathlib import Path

import cv2
import numpy as np

from ops.geometry.mesh import points_in_domain
from ops.geometry.polygon import polygon_area
from ops.segmentation.domain import closed_holes, glued_gaps, mesh_domain
from ops.segmentation.masks import build_masks
from ops.shotio.image_io import read_image
from ops.shotio.load import load_shot

SAMPLES = Path(__file__).resolve().parents[3] / "data_samples"


def _pixels(mask):
    ys, xs = np.nonzero(mask)
    return np.stack([xs, ys], 1).astype(float)


def test_ring_has_an_outline_a_hole_outline_and_a_point_in_the_hole():
    img = np.zeros((80, 80), np.uint8)
    cv2.circle(img, (40, 40), 30, 1, -1)
    cv2.circle(img, (40, 40), 14, 0, -1)
    fg = img.astype(bool)
    loops, holes = mesh_domain(fg, fg.astype(np.float32))
    areas = sorted(polygon_area(L) for L in loops)
    assert len(loops) == 2 and areas[0] < 0 < areas[1]
    assert len(holes) == 1 and np.linalg.norm(holes[0] - 40) < 3
    assert points_in_domain(_pixels(fg), loops).all()
    inner_paper = _pixels(np.hypot(*np.mgrid[0:80, 0:80] - 40) < 10)
    assert not points_in_domain(inner_paper, loops).any()  # the hole stays open (the margin is 2 px)


def test_soft_fringe_is_inside_and_components_are_separate():
    fg = np.zeros((60, 100), bool)
    fg[10:30, 10:30] = True
    fg[10:30, 60:90] = True
    cov = fg.astype(np.float32)
    cov[9, 10:30] = 0.3  # an anti-aliased fringe row outside the hard mask
    loops, holes = mesh_domain(fg, cov)
    assert len(loops) == 2 and len(holes) == 0 and all(polygon_area(L) > 0 for L in loops)
    assert points_in_domain(_pixels(cov > 0), loops).all()
    assert not points_in_domain(np.array([[45.0, 20.0]]), loops).any()  # the paper between them is not meshed


def test_a_narrow_hole_stays_open():
    """The space between a hand on the hip and the torso: 4 px of paper that the 2 px margin would close."""
    fg = np.zeros((60, 60), bool)
    fg[10:50, 10:50] = True
    slit = np.zeros_like(fg)
    slit[20:40, 28:32] = True  # 4 px wide, 20 px tall, enclosed
    fg &= ~slit
    cov = fg.astype(np.float32)
    closed_loops, closed_holes = mesh_domain(fg, cov)
    assert len(closed_holes) == 0  # without the holes, the margin glues the two sides together
    loops, holes = mesh_domain(fg, cov, slit)
    assert len(loops) == 2 and len(holes) == 1 and slit[int(holes[0][1]), int(holes[0][0])]
    assert points_in_domain(_pixels(fg), loops).all()
    core = slit & ~(cv2.dilate(fg.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0)
    assert core.sum() == 2 * 18 and not points_in_domain(_pixels(core), loops).any()  # all but a pixel of margin


def test_a_sliver_of_paper_is_closed_over_and_a_wide_hole_stays_open():
    """Paper 2 px wide between two bodies gets no hole in the mesh (a pixel of margin on each side closes it):
    closed_holes says the mesh holds it, as contacts must know. A 6 px hole stays open, all but its margin."""
    fg = np.zeros((60, 90), bool)
    fg[10:50, 10:80] = True
    sliver, wide = np.zeros_like(fg), np.zeros_like(fg)
    sliver[20:40, 28:30] = True
    wide[20:40, 57:63] = True
    fg &= ~(sliver | wide)
    cov = fg.astype(np.float32)
    closed = closed_holes(fg, cov, sliver | wide)
    assert (closed & sliver).sum() == sliver.sum()
    loops, _ = mesh_domain(fg, cov, sliver | wide)
    assert points_in_domain(_pixels(sliver), loops).all()  # the mesh does hold it
    open_core = _pixels(wide & ~closed)  # all but the margin (the simplified outline blurs its edge pixels)
    assert len(open_core) >= 2 * 16 and points_in_domain(open_core, loops).mean() < 0.25


def test_every_hole_seed_lies_outside_the_simplified_domain():
    """legs_cross key0 has a sliver of a hole (1-2 px wide) between the crossing legs that the simplified outline
    no longer encloses: it is meshed over, since its seed inside the domain would make the mesher eat the mesh."""
    shot = load_shot(SAMPLES / "legs_cross")
    masks = build_masks(read_image(shot.keyframes[0]), shot.key_pose(0), shot.skeleton, occlusion="skeleton")
    loops, seeds = mesh_domain(masks.foreground, masks.coverage, masks.holes)
    assert masks.holes.sum() > 0 and not points_in_domain(seeds, loops).any()


def arm_beside_body(gap: int = 2):
    """(120, 120) bool foreground: a torso and an arm hanging `gap` px beside it, joined at the shoulder and open
    below, as drawn with the arm just off the body; and the paper between them."""
    fg = np.zeros((120, 120), bool)
    fg[20:100, 30:60] = True  # torso
    fg[20:28, 30:73 + gap] = True  # shoulder
    fg[20:90, 60 + gap:72 + gap] = True  # arm
    between = np.zeros_like(fg)
    between[28:90, 60:60 + gap] = True
    return fg, between


def test_paper_the_margin_closes_between_two_parts_is_a_glued_gap():
    """An arm 2 px beside the body: the domain's 2 px margin closes the paper between them (the mesh would glue
    the arm to the body), and glued_gaps finds it, whole and alone."""
    fg, between = arm_beside_body(2)
    cov = fg.astype(np.float32)
    loops, _ = mesh_domain(fg, cov)
    assert points_in_domain(_pixels(between), loops).all()  # the margin has glued it
    gaps = glued_gaps(fg, cov)
    assert len(gaps) == 1 and (gaps[0] & between).sum() == between.sum()
    assert not (gaps[0] & fg).any() and gaps[0].sum() <= between.sum() + 4  # paper only: at most the mouth's corner


def test_no_glued_gap_where_the_margin_leaves_paper_open_or_in_a_hole_or_a_corner():
    fg, _ = arm_beside_body(6)  # 6 px apart: the margin leaves the paper between them open
    assert glued_gaps(fg, fg.astype(np.float32)) == []
    fg, between = arm_beside_body(2)
    fg[90:100, 60:74] = True  # the hand joins the hip: the paper between them is a hole now, meshed open
    assert glued_gaps(fg, fg.astype(np.float32), between) == []
    short = np.zeros((60, 60), bool)
    short[10:50, 10:30] = True
    short[10:16, 32:50] = True  # a flag 2 px off a pole for 6 px: a corner, not two parts apart
    assert glued_gaps(short, short.astype(np.float32)) == []
