"""Stage previews: shapes, size limits and colours at known pixels."""
import numpy as np
import pytest

from ops.preview import (
    DISTORTED_TINT,
    FG_TINT,
    FG_WEIGHT,
    FRONT_COLOUR,
    HANDLE_COLOUR,
    MAX_WIDTH,
    OCC_WEIGHT,
    POCKET_OFFSET,
    POINT_COLOUR,
    SLIT_COLOUR,
    checkerboard,
    frame_strip,
    mask_overlay,
    region_colour,
    save_preview,
    side_by_side,
    strip_thumb_width,
    to_png_bytes,
    wireframe,
)
from ops.shotio.image_io import read_image

H, W = 96, 128


def _white():
    return np.ones((H, W, 3), np.float32)


def _u8(img, y, x):
    return np.round(img[y, x] * 255).astype(int)


def test_mask_overlay_colours():
    fg = np.zeros((H, W), bool); fg[10:90, 10:120] = True
    occ0 = np.zeros_like(fg); occ0[20:40, 20:40] = True
    occ1 = np.zeros_like(fg); occ1[50:70, 60:90] = True
    img = mask_overlay(_white(), fg, [occ0, occ1])
    assert img.shape == (H, W, 3) and img.dtype == np.float32
    tinted = (1 - FG_WEIGHT) * 1.0 + FG_WEIGHT * np.array(FG_TINT) / 255
    np.testing.assert_array_equal(_u8(img, 0, 0), [255, 255, 255])                     # background
    np.testing.assert_allclose(img[15, 15], tinted, atol=0.6 / 255)                      # foreground
    for occ_pixel, i in (((30, 30), 0), ((60, 70), 1)):
        expected = (1 - OCC_WEIGHT) * tinted + OCC_WEIGHT * np.array(region_colour(i)) / 255
        np.testing.assert_allclose(img[occ_pixel], expected, atol=0.6 / 255)
    assert np.abs(img[30, 30] - img[60, 70]).max() > 0.1                                # distinct regions


def test_mask_overlay_boundaries_and_points():
    fg = np.ones((H, W), bool)
    square = np.array([[20, 20], [60, 20], [60, 50], [20, 50]], float)
    img = mask_overlay(_white(), fg, [np.zeros((H, W), bool)], boundaries=[square],
                       points=[np.array([[100.0, 70.0]])])
    dark = [int(c * 0.6) for c in region_colour(0)]
    np.testing.assert_array_equal(_u8(img, 20, 40), dark)      # on the top edge (y = 20)
    np.testing.assert_array_equal(_u8(img, 35, 20), dark)      # closed: the left edge joins back
    np.testing.assert_array_equal(_u8(img, 70, 104), POINT_COLOUR)  # circle radius 4 around (100, 70)
    assert not np.array_equal(_u8(img, 70, 100), POINT_COLOUR)     # hollow centre


def test_mask_overlay_draws_slits_open():
    fg = np.ones((H, W), bool)
    slit = np.array([[20, 30], [60, 30], [60, 60]], float)
    img = mask_overlay(_white(), fg, [], slits=[slit])
    np.testing.assert_array_equal(_u8(img, 30, 40), SLIT_COLOUR)  # along the first piece
    np.testing.assert_array_equal(_u8(img, 45, 60), SLIT_COLOUR)  # along the second
    assert not np.array_equal(_u8(img, 45, 40), SLIT_COLOUR)      # open: no edge back from the end


def test_mask_overlay_downscales_wide_images():
    big = np.ones((300, 1200, 4), np.float32)
    fg = np.zeros((300, 1200), bool)
    img = mask_overlay(big, fg, [], boundaries=[np.array([[0, 0], [1199, 299]], float)])
    assert img.shape == (128, 512, 3) and img.shape[1] <= MAX_WIDTH


def test_wireframe_layers_and_handles():
    V = np.array([[10, 10], [50, 10], [30, 40], [60, 60]], float)
    F = np.array([[0, 1, 2], [0, 1, 2], [1, 3, 2]])
    layer = np.array([0, 1, 0])
    img = wireframe(_white(), V, F, layer, handles=np.array([3]))
    assert img.shape == (H, W, 3)
    np.testing.assert_array_equal(_u8(img, 10, 30), FRONT_COLOUR)                 # front edge y = 10
    off = int(POCKET_OFFSET)
    np.testing.assert_array_equal(_u8(img, 10 + off, 30 + off), region_colour(0))  # pocket, shifted
    np.testing.assert_array_equal(_u8(img, 60, 60), HANDLE_COLOUR)                # handle dot
    np.testing.assert_allclose(img[90, 5], 1.0)                                    # faded white paper


def test_frame_strip_width_and_checkerboard():
    T = 5
    frames = np.zeros((T, 40, 60, 4), np.float32)
    frames[:, :20, :, :3] = 0.2; frames[:, :20, :, 3] = 1.0   # top opaque, bottom transparent
    strip = frame_strip(frames)
    tw = strip_thumb_width(T, 60)
    assert tw == 60 and strip.shape == (40, T * tw, 3)
    np.testing.assert_allclose(strip[5, 5], 0.2, atol=1e-6)
    board = checkerboard(40, 60)
    np.testing.assert_allclose(strip[30:, :60], board[30:], atol=1e-6)   # transparent shows the board
    assert board.min() < board.max()
    many = frame_strip(np.zeros((30, 100, 200, 4), np.float32), max_frames=9)
    tw = strip_thumb_width(9, 200)
    assert many.shape[1] == 9 * tw and tw * 9 <= 1.2 * MAX_WIDTH


def test_frame_strip_tints_marked_pixels_only():
    frames = np.zeros((3, 40, 60, 4), np.float32)
    frames[..., :3], frames[..., 3] = 0.8, 1.0
    torn = np.zeros((3, 40, 60), bool)
    torn[1, 10:20, 10:20] = True  # frame 1 only
    strip = frame_strip(frames, marks=[(torn, DISTORTED_TINT)])
    np.testing.assert_allclose(strip[15, 60 + 15], 0.5 * 0.8 + 0.5 * np.array(DISTORTED_TINT), atol=1e-6)
    np.testing.assert_allclose(strip[15, 15], 0.8, atol=1e-6)  # the same pixel of frame 0
    np.testing.assert_allclose(strip[30, 60 + 30], 0.8, atol=1e-6)  # frame 1 outside the mark


def test_side_by_side_labels_and_width():
    a = np.zeros((100, 300, 4), np.float32); a[..., 3] = 1.0
    b = np.ones((50, 100, 3), np.float32)
    img = side_by_side([a, b], ["ours", "gt"])
    assert img.ndim == 3 and img.shape[2] == 3 and img.shape[1] <= MAX_WIDTH
    assert img[:18].min() < 0.5          # label text is drawn in the band
    assert img[30, 10].max() == 0.0      # first image (black) below the band
    with pytest.raises(ValueError):
        side_by_side([a], ["x", "y"])


def test_png_bytes_and_save(tmp_path):
    img = np.zeros((8, 10, 3), np.float32); img[..., 0] = 1.0
    data = to_png_bytes(img)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    p = save_preview(tmp_path / "p.png", img)
    np.testing.assert_array_equal(read_image(p), img)
