"""Redrawn keys (redraw.py) and the solids they need: eggs, bulging and bent limbs, answers known in closed form."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from data_samples.generator.bodies3d import make_body
from data_samples.generator.redraw import ASPECT, Change, carried, changed_solid, draw_redraw, redrawn_body
from data_samples.generator.solids import cast, ellipsoid, grid, limb, transformed


def _egg(e: float):
    return replace(ellipsoid(np.array([50.0, 50.0, 100.0]), np.eye(3), (20.0, 10.0, 8.0), 0), egg=e)


def test_an_egg_is_two_half_ellipsoids():
    """A ray through (x, y) enters the half x >= 50 of the ellipsoid with radii (20 (1 + e), 10, 8), and the
    other half of the one with 20 (1 - e), where its formula says."""
    e = 0.3
    xs, ys = grid(20.0, 42.0, 60, 16, 1.0)
    entry, leave = cast(_egg(e), xs, ys)
    a = np.where(xs >= 50, 20 * (1 + e), 20 * (1 - e))
    inside = ((xs - 50) / a) ** 2 + ((ys - 50) / 10) ** 2
    half = 8 * np.sqrt(np.clip(1 - inside, 0, None))
    hit = inside < 1
    assert np.array_equal(np.isfinite(entry), hit)
    np.testing.assert_allclose(entry[hit], 100 - half[hit], atol=1e-9)
    np.testing.assert_allclose(leave[hit], 100 + half[hit], atol=1e-9)


def test_an_egg_of_nought_is_the_ellipsoid_and_its_extent_bounds_it():
    xs, ys = grid(20.0, 30.0, 60, 40, 0.5)
    plain, egg0 = cast(_egg(0.0), xs, ys), cast(ellipsoid(np.array([50.0, 50.0, 100.0]), np.eye(3), (20.0, 10.0, 8.0),
                                                          0), xs, ys)
    assert np.array_equal(plain[0], egg0[0])
    turned = transformed(_egg(0.25), np.array([[0.6, -0.8, 0], [0.8, 0.6, 0], [0, 0, 1.0]]), 1.0, np.zeros(3))
    lo, hi = turned.extent()
    xs, ys = grid(lo[0] - 5, lo[1] - 5, int(hi[0] - lo[0]) + 10, int(hi[1] - lo[1]) + 10, 0.5)
    hit = np.isfinite(cast(turned, xs, ys)[0])
    assert hit.any() and (xs[hit] >= lo[0]).all() and (xs[hit] <= hi[0]).all() and (ys[hit] <= hi[1]).all()


def test_a_bulging_bent_limb_is_wider_at_its_peak_and_sags_by_its_bend():
    """A limb along x from 0 to 100, radius 5: bulge 0.4 at 0.3 of its length makes it 2 * 5 * 1.4 wide there;
    bend (0, 12, 0) moves its middle down 12 px; its ends keep their radius."""
    base = limb(np.array([0.0, 50.0, 100.0]), np.array([100.0, 50.0, 100.0]), 5.0, 5.0, 0)
    bulged = replace(base, bulge=0.4, peak=0.3)
    bent = replace(base, bend=np.array([0.0, 12.0, 0.0]))

    def column(s, x):
        xs, ys = grid(x, 30.0, 1, 400, 0.1)
        hit = np.isfinite(cast(s, xs, ys)[0])[:, 0]
        return ys[hit, 0]

    at_peak = column(bulged, 30.0)
    assert abs(np.ptp(at_peak) - 14.0) < 0.3
    assert abs(np.ptp(column(bulged, 1.0)) - np.ptp(column(base, 1.0))) < 0.5  # the joint end about as it was
    mid = column(bent, 50.0)
    assert abs(mid.mean() - 62.0) < 0.2 and abs(np.ptp(mid) - 10.0) < 0.3
    lo, hi = bent.extent()
    assert lo[1] <= 45.0 + 1e-9 and hi[1] >= 67.0 - 1e-9


@pytest.fixture(scope="module")
def body():
    return make_body(np.random.default_rng(3), "round")


def test_amount_nought_changes_nothing(body):
    rd = draw_redraw(np.random.default_rng(1), body.solids, 0.0, (64, 64), 0.5)
    for t in (0.0, 0.5, 1.0):
        again = redrawn_body(body, rd.at(t))
        assert all(a is b for a, b in zip(again.solids, body.solids))
        assert all(np.array_equal(a.points, b.points) for a, b in zip(again.marks, body.marks))
        assert rd.rewobble(t) is None


def test_each_solid_changes_its_aspect_between_the_keys_by_the_amount(body):
    """Key1's thickness against length over key0's is exp(+-(0.5 .. 1) ASPECT amount) for every solid; at
    t = 0.5 every parameter is halfway."""
    amount = 0.8
    rd = draw_redraw(np.random.default_rng(1), body.solids, amount, (64, 64), 0.5)
    for s, c0, c1 in zip(body.solids, *rd.keys):
        a0, a1 = changed_solid(s, c0), changed_solid(s, c1)
        if s.kind == "limb":
            change = 0.5 * math.log(a1.radii.prod() / a0.radii.prod())  # the taper cancels in the product
        else:
            change = math.log((a1.radii[0] / a1.radii[1]) / (a0.radii[0] / a0.radii[1]))
        assert 0.5 * ASPECT * amount - 1e-9 <= abs(change) <= ASPECT * amount + 1e-9, (s.name, change)
    mid = rd.at(0.5)[0]
    k0, k1 = rd.keys[0][0], rd.keys[1][0]
    assert mid.bulge == pytest.approx((k0.bulge + k1.bulge) / 2)
    assert mid.bend[1] == pytest.approx((k0.bend[1] + k1.bend[1]) / 2)
    assert rd.rewobble(0.0).angle == 0.0 and rd.rewobble(1.0).angle == pytest.approx(amount * math.pi / 2)


def test_marks_ride_on_the_changed_surface():
    """A point on an ellipsoid's surface, carried onto the same ellipsoid changed (aspect and egg), lies on the
    changed one's surface: its half's implicit function is 1."""
    s = ellipsoid(np.array([1.0, 2.0, 3.0]), np.eye(3), (10.0, 6.0, 4.0), 0)
    after = changed_solid(s, Change(log_aspect=0.2, egg=0.15))
    d = np.array([[0.6, 0.3, 0.74], [-0.5, 0.2, 0.84]])
    on = s.centre + d / np.linalg.norm(d / s.radii, axis=1, keepdims=True)
    q = carried(on, s, after) - after.centre
    a = np.where(q[:, 0] >= 0, after.radii[0] * (1 + after.egg), after.radii[0] * (1 - after.egg))
    np.testing.assert_allclose((q[:, 0] / a) ** 2 + (q[:, 1] / after.radii[1]) ** 2 + (q[:, 2] / after.radii[2]) ** 2,
                               1.0, atol=1e-9)
