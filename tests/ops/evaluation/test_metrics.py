"""Evaluation metrics on inputs with known answers."""
import numpy as np
import pytest

from ops.evaluation.metrics import chamfer, ink_mask, ink_threshold, luminance, psnr, ssim


def _drawing(H=64, W=80, seed=0):
    rng = np.random.default_rng(seed)
    img = np.ones((H, W, 4), np.float32)
    img[..., :3] = rng.random((H, W, 1)) * 0.3 + 0.7
    img[20:40, 10:60, :3] = 0.1
    return img


def test_identical_images():
    img = _drawing()
    assert psnr(img, img) == np.inf
    assert ssim(img, img) == pytest.approx(1.0)
    assert chamfer(img, img) == 0.0


def test_psnr_of_constant_offset():
    a = np.full((16, 16, 3), 0.4)
    for d in (0.1, 0.01, 1 / 255):
        assert psnr(a, a + d) == pytest.approx(-20 * np.log10(d), rel=1e-9)
    assert psnr(a, a + 0.1) == pytest.approx(20.0, rel=1e-9)


def test_chamfer_one_pixel_shift_of_vertical_line():
    H, W = 50, 70
    a = np.ones((H, W, 3), np.float32); b = a.copy()
    a[:, 30] = 0.0; b[:, 31] = 0.0
    diag = np.sqrt(H ** 2 + W ** 2)
    expected = (1.0 + 1.0) / 2.0 / diag * 1e5
    assert chamfer(a, b) == pytest.approx(expected, rel=1e-12)
    # shift by 3: every ink pixel is 3 away
    c = np.ones_like(a); c[:, 33] = 0.0
    assert chamfer(a, c) == pytest.approx(3.0 / diag * 1e5, rel=1e-12)


def test_chamfer_asymmetric_sets_average_both_directions():
    H, W = 20, 20
    a = np.zeros((H, W), bool); b = np.zeros((H, W), bool)
    a[5, 5] = True
    b[5, 5] = True; b[5, 9] = True          # a->b: 0; b->a: (0 + 4) / 2 = 2
    assert chamfer(a, b) == pytest.approx(0.5 * (0 + 2) / np.hypot(H, W) * 1e5)
    assert chamfer(a, b) == pytest.approx(chamfer(b, a))


def test_chamfer_empty_cases():
    e = np.zeros((10, 10), bool); f = e.copy(); f[3, 3] = True
    assert chamfer(e, e) == 0.0
    assert chamfer(e, f) == np.inf and chamfer(f, e) == np.inf


def _ring_drawing(ink: float, paper: float, shift: int = 0) -> np.ndarray:
    """(64, 64, 3) a ring 2 px wide drawn in grey `ink` on grey `paper`, moved `shift` px right."""
    yy, xx = np.mgrid[:64, :64]
    r = np.hypot(yy - 32.0, xx - 30.0 - shift)
    img = np.full((64, 64, 3), paper, np.float32)
    img[(r > 14) & (r < 16)] = ink
    return img


def test_pale_lines_are_ink_for_chamfer_where_the_fixed_level_finds_none():
    """A drawing in lines paler than 0.5 (AnimatedDrawings' char5, crayon): its Chamfer is the one the same
    drawing in dark ink gives, not an empty set against specks; drawings with dark ink keep the 0.5 level."""
    dark, pale = _ring_drawing(0.1, 1.0), _ring_drawing(0.75, 0.95)
    assert ink_threshold(dark) == 0.5 and ink_threshold(pale) == pytest.approx(0.85)
    moved_dark, moved_pale = _ring_drawing(0.1, 1.0, 3), _ring_drawing(0.75, 0.95, 3)
    want = chamfer(moved_dark, dark)
    assert 0 < want < np.inf
    assert chamfer(moved_pale, pale) == 0.0  # the fixed level finds no ink in either: the move goes unseen
    assert chamfer(moved_pale, pale, ink_threshold(pale)) == pytest.approx(want)


def test_ink_mask_composites_over_white():
    img = np.zeros((2, 2, 4), np.float32)   # black ink everywhere ...
    img[0, 0, 3] = 1.0                      # ... opaque here
    img[0, 1, 3] = 0.3                      # faint: over white luminance 0.7 -> no ink
    img[1, 0, 3] = 0.7                      # luminance 0.3 -> ink
    np.testing.assert_array_equal(ink_mask(img), [[True, False], [True, False]])
    np.testing.assert_allclose(luminance(np.ones((1, 1, 3)) * [1, 0, 0]), 0.2126)


def test_ssim_drops_with_noise():
    a = _drawing()
    rng = np.random.default_rng(3)
    noisy = a.copy(); noisy[..., :3] = np.clip(a[..., :3] + rng.normal(0, 0.2, a[..., :3].shape), 0, 1)
    s = ssim(a, noisy)
    assert 0.0 < s < 0.9


def test_psnr_reads_rgba_as_drawn_on_white():
    transparent = np.zeros((8, 8, 4))              # RGB black but fully transparent = blank paper
    paper = np.ones((8, 8, 4))
    assert psnr(transparent, paper) == np.inf
    ink = paper.copy()
    ink[0, 0, :3] = 0.0                             # one opaque black pixel out of 64
    assert psnr(ink, paper) == pytest.approx(10 * np.log10(64 * 3 / 3), rel=1e-9)


def test_paper_plate_gives_back_each_keyframe_and_over_is_exact():
    from ops.evaluation.plate import over, paper_plate

    rng = np.random.default_rng(3)
    paper = (0.9 + 0.05 * rng.random((20, 30, 3))).astype(np.float32)  # grainy, tinted
    key0, key1 = paper.copy(), paper.copy()
    c0, c1 = np.zeros((20, 30), np.float32), np.zeros((20, 30), np.float32)
    c0[5:10, 5:10], c1[8:15, 12:20] = 1.0, 1.0
    key0[c0 > 0], key1[c1 > 0] = 0.1, 0.2
    smooth = np.full((20, 30, 3), 0.92, np.float32)
    plate = paper_plate([key0, key1], [c0, c1], [smooth, smooth])
    assert np.array_equal(plate[c0 == 0], key0[c0 == 0])  # key0's own paper, grain included
    assert np.array_equal(plate[(c0 > 0) & (c1 == 0)], key1[(c0 > 0) & (c1 == 0)])  # uncovered by key1
    rgb = np.broadcast_to(np.where(c0[..., None] > 0, 0.1, 0.5), (20, 30, 3))
    rgba = np.concatenate([rgb, c0[..., None]], 2).astype(np.float32)
    assert np.allclose(over(rgba[None], plate)[0], key0)  # our frame 0 over the plate is keyframe 0
    assert np.array_equal(over(key1[None], plate)[0], key1)  # opaque frames are unchanged
