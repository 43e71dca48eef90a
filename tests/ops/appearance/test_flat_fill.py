"""Tests of the flat-colour inpainter, its stroke continuation and its per-hole choice of Telea."""
from __future__ import annotations

import numpy as np
import pytest

from ops.appearance.flat_fill import FlatInpainter
from ops.appearance.inpaint import OpenCVInpainter, inpaint, make_inpainter
from ops.appearance.inpaint_preview import inpaint_preview
from ops.appearance.strokes import StrokeEnd, hermite, pair_ends

S = 96
YY, XX = np.mgrid[0:S, 0:S]
GREEN, INK, PALE = (0.4, 0.7, 0.3), (0.1, 0.2, 0.1), (0.9, 0.9, 0.6)
HOLE = (np.abs(XX - 48) <= 10) & (np.abs(YY - 48) <= 14)


def disc(colour=GREEN) -> tuple[np.ndarray, np.ndarray]:
    """A flat disc of radius 40 on white: (image (S, S, 3) float32, coverage (S, S) float32)."""
    img = np.ones((S, S, 3), np.float32)
    inside = (XX - 48) ** 2 + (YY - 48) ** 2 <= 40**2
    img[inside] = colour
    return img, inside.astype(np.float32)


def line_distance(angle_deg: float, through=(48.0, 50.0)) -> np.ndarray:
    """(S, S) distance of every pixel centre to the line through `through` at angle_deg."""
    t = np.radians(angle_deg)
    return np.abs((XX - through[0]) * -np.sin(t) + (YY - through[1]) * np.cos(t))


def covered(image: np.ndarray, hole: np.ndarray, fill=(0.9, 0.2, 0.2)) -> np.ndarray:
    """The image with the hole painted over (what a covering part shows there)."""
    out = image.copy()
    out[hole] = fill
    return out


def test_flat_disc_fills_with_exactly_its_colour():
    img, cov = disc()
    out, plans = FlatInpainter("auto").fill(covered(img, HOLE), HOLE, cov)
    assert [p.method for p in plans] == ["flat"]
    assert np.abs(out[HOLE] - np.float32(GREEN)).max() < 1e-6
    assert np.array_equal(out[~HOLE], covered(img, HOLE)[~HOLE])  # nothing outside the hole changes


@pytest.mark.parametrize("angle", [0.0, 20.0, 37.0, -55.0])
def test_straight_line_is_continued_straight(angle):
    img, cov = disc()
    dist = line_distance(angle)
    img[(dist <= 1.5) & (cov > 0)] = INK  # a 3 px line across the disc and through the hole
    out, plans = FlatInpainter("auto").fill(covered(img, HOLE), HOLE, cov)
    assert plans[0].method == "flat" and len(plans[0].pairs) == 1
    ink = HOLE & (np.linalg.norm(out - np.float32(INK), axis=2) < np.linalg.norm(out - np.float32(GREEN), axis=2))
    # the continued stroke's pixels lie within 1 px of the drawn line (its centre line +- half its width)
    assert ink.any() and dist[ink].max() <= 1.5 + 1.0
    # and it is unbroken: every hole pixel on the centre line is ink
    assert ink[HOLE & (dist <= 0.5)].all()


def test_two_colours_split_by_a_line_stay_split():
    img, cov = disc()
    dist = line_distance(15.0)
    above = (YY - 50) < np.tan(np.radians(15.0)) * (XX - 48)
    img[above & (cov > 0)] = PALE
    img[(dist <= 1.5) & (cov > 0)] = INK
    out, plans = FlatInpainter("auto").fill(covered(img, HOLE), HOLE, cov)
    assert plans[0].method == "flat"
    far = HOLE & (dist > 3.0)
    assert np.abs(out[far & above] - np.float32(PALE)).max() < 1e-6
    assert np.abs(out[far & ~above] - np.float32(GREEN)).max() < 1e-6


def test_outline_along_the_hole_is_not_continued():
    """The covering part's own outline runs along the hole's boundary: it bounds the pocket, it crosses nothing."""
    img, cov = disc()
    rim = (np.abs(XX - 48) <= 12) & (np.abs(YY - 48) <= 16) & ~HOLE
    img[rim] = INK
    out, plans = FlatInpainter("auto").fill(covered(img, HOLE), HOLE, cov)
    assert plans[0].method == "flat" and plans[0].ends == []
    assert np.abs(out[HOLE] - np.float32(GREEN)).max() < 1e-6  # no ink smeared in


def test_noisy_texture_keeps_telea():
    rng = np.random.default_rng(0)
    img, cov = disc()
    img = np.clip(img + rng.normal(0.0, 0.08, img.shape), 0, 1).astype(np.float32)
    ctx = covered(img, HOLE)
    out, plans = FlatInpainter("auto").fill(ctx, HOLE, cov)
    assert [p.method for p in plans] == ["telea"]
    assert np.array_equal(out, OpenCVInpainter()(ctx, HOLE))


def test_per_hole_choice():
    """Two holes, one in a flat disc, one in a noisy one: flat fill for the first, Telea for the second."""
    rng = np.random.default_rng(1)
    img = np.ones((S, 2 * S, 3), np.float32)
    cov = np.zeros((S, 2 * S), np.float32)
    a, _ = disc()
    b, c = disc((0.6, 0.5, 0.3))
    b = np.clip(b + rng.normal(0.0, 0.08, b.shape), 0, 1).astype(np.float32)
    img[:, :S], img[:, S:] = a, b
    cov[:, :S], cov[:, S:] = c, c
    hole = np.concatenate([HOLE, HOLE], axis=1)
    out, plans = FlatInpainter("auto").fill(covered(img, hole), hole, cov)
    methods = {int(p.pixels[0, 1] >= S): p.method for p in plans}
    assert methods == {0: "flat", 1: "telea"}
    assert np.abs(out[:, :S][HOLE] - np.float32(GREEN)).max() < 1e-6


def test_flat_mode_fills_a_textured_hole_flat():
    rng = np.random.default_rng(2)
    img, cov = disc()
    img = np.clip(img + rng.normal(0.0, 0.02, img.shape), 0, 1).astype(np.float32)
    _, plans = FlatInpainter("flat").fill(covered(img, HOLE), HOLE, cov)
    assert plans[0].method == "flat"


def test_hermite_reproduces_a_segment_and_meets_its_tangents():
    p0, p1 = np.array([2.0, 3.0]), np.array([12.0, 8.0])
    c = (p1 - p0) / np.linalg.norm(p1 - p0)
    curve = hermite(p0, c, p1, c)
    assert np.allclose(curve[0], p0) and np.allclose(curve[-1], p1)
    off = np.abs((curve - p0) @ np.array([-c[1], c[0]]))
    assert off.max() < 1e-9
    bent = hermite(p0, np.array([1.0, 0.0]), p1, np.array([0.0, 1.0]))
    start, end = bent[1] - bent[0], bent[-1] - bent[-2]
    assert abs(start[1] / start[0]) < 0.05 and abs(end[0] / end[1]) < 0.05


def test_pairing_prefers_the_straight_partner_and_flags_near_ties():
    hole = np.zeros((60, 60), bool)
    hole[10:50, 10:50] = True
    colour = np.float32(INK)

    def end(x, y, dx, dy):
        d = np.array([dx, dy], float)
        return StrokeEnd(np.array([x, y], float), d / np.linalg.norm(d), 2.0, colour, np.zeros((0, 2), np.int64))

    # two parallel horizontal lines: straight pairs, not crossed ones
    ends = [end(10, 20, 1, 0), end(10, 40, 1, 0), end(49, 20, -1, 0), end(49, 40, -1, 0)]
    pairs, unpaired = pair_ends(ends, hole)
    assert sorted((p.a, p.b) for p in pairs) == [(0, 2), (1, 3)] and unpaired == []
    # an end with two mirror-image partners: the choice is a tie, and it says so
    tie = [end(10, 30, 1, 0), end(49, 26, -1, 0.1), end(49, 34, -1, -0.1)]
    pairs, unpaired = pair_ends(tie, hole)
    assert len(pairs) == 1 and pairs[0].ambiguous and len(unpaired) == 1


def test_inpaint_adapter_and_methods():
    img, cov = disc()
    ctx = covered(img, HOLE)

    def legacy(image, hole):  # an inpainter written for the first protocol: no coverage argument
        out = image.copy()
        out[hole] = 0.5
        return out

    assert np.allclose(inpaint(legacy, ctx, HOLE, cov)[HOLE], 0.5)
    for method in ("telea", "ns", "flat", "auto"):
        out = inpaint(make_inpainter(method), ctx, HOLE, cov)
        assert out.shape == ctx.shape and np.array_equal(out[~HOLE], ctx[~HOLE])
    with pytest.raises(ValueError, match="inpainter method"):
        make_inpainter("lama")
    with pytest.raises(ValueError, match="radius"):
        make_inpainter("auto", radius=0)


def test_preview_shows_every_panel():
    img, cov = disc()
    dist = line_distance(20.0)
    img[(dist <= 1.5) & (cov > 0)] = INK
    ctx = covered(img, HOLE)
    out, plans = FlatInpainter("auto").fill(ctx, HOLE, cov)
    pv = inpaint_preview(ctx, HOLE, plans, out, OpenCVInpainter()(ctx, HOLE), truth=img, scale=2)
    assert pv.dtype == np.float32 and pv.ndim == 3 and pv.shape[1] > 4 * pv.shape[0] * 0.5
    assert 0.0 <= pv.min() and pv.max() <= 1.0
