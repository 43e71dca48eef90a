"""Tests of ops.blending.crop: the box around the ink, snapped to the network's grid, and the cut-edge test."""
import torch

from ops.blending.crop import Box, coverage_box, cuts_ink, grow


def test_box_of_one_pixel_is_margin_then_grid_snapped():
    """A pixel at (50, 70) of a 128 x 160 frame: [50 - 32, 51 + 32) snapped to 32 -> [0, 96), x [32, 128)."""
    alpha = torch.zeros(128, 160)
    alpha[50, 70] = 0.2
    assert coverage_box(alpha, margin=32, grid=32) == Box(0, 96, 32, 128)
    assert coverage_box(alpha, margin=0, grid=1) == Box(50, 51, 70, 71)


def test_box_is_the_union_over_images_and_clipped_to_the_frame():
    """Ink in two images at opposite corners: the box spans both and never leaves the frame."""
    alpha = torch.zeros(2, 100, 90)
    alpha[0, 2, 3] = 1.0
    alpha[1, 97, 88] = 1.0
    assert coverage_box(alpha, margin=8, grid=16) == Box(0, 100, 0, 90)
    alpha[1] = 0.0
    assert coverage_box(alpha, margin=8, grid=16) == Box(0, 16, 0, 16)


def test_no_ink_gives_no_box():
    assert coverage_box(torch.zeros(3, 40, 40)) is None


def test_grow_adds_the_margin_and_stops_at_the_frame():
    box = Box(64, 96, 32, 64)
    assert grow(box, (200, 100), margin=32, grid=32) == Box(32, 128, 0, 96)
    assert grow(Box(0, 200, 0, 100), (200, 100)) == Box(0, 200, 0, 100)


def test_ink_on_a_cut_edge_counts_but_not_on_the_frame_edge():
    """Coverage on the box's top row: cut when the box starts inside the frame, not when it starts at row 0."""
    alpha = torch.zeros(1, 32, 32)
    alpha[0, 0, 10] = 0.5
    assert cuts_ink(alpha, Box(32, 64, 0, 32), (128, 128))
    assert not cuts_ink(alpha, Box(0, 32, 0, 32), (128, 128))
    alpha[0, 0, 10] = 1e-4  # a trace below the ink threshold is paper
    assert not cuts_ink(alpha, Box(32, 64, 0, 32), (128, 128))
    alpha[0, 16, -1] = 1.0  # right edge, inside the frame
    assert cuts_ink(alpha, Box(0, 32, 0, 32), (128, 128))
