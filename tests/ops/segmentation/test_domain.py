"""The meshed domain: every pixel with coverage inside, holes left open, one outline per component."""
from pathlib import Path

import cv2
import numpy as np

from ops.geometry.mesh import points_in_domain
from ops.geometry.polygon import polygon_area
from ops.segmentation.domain import closed_holes, mesh_domain
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
