"""T-junctions read off a depth buffer: a bar in front of a disc ends the disc's outline at two known points."""
from __future__ import annotations

import numpy as np

from data_samples.generator.junctions3d import depth_order, pair_junctions
from data_samples.generator.occlusion import junction_stems

S = 96
CX, CY, R = 44.0, 48.0, 26.0
Y0, Y1 = 42, 54  # the bar's rows


def _scene(bar_in_front: bool = True, cover_right: bool = False) -> tuple[dict, dict]:
    """cover, entry of a disc (bone 0) and a bar across it out past its right side (bone 1), and optionally a
    box (bone 2) nearer than both over the right-hand crossings."""
    yy, xx = np.mgrid[0:S, 0:S].astype(np.float64)
    disc = (xx - CX) ** 2 + (yy - CY) ** 2 <= R**2
    bar = (yy >= Y0) & (yy <= Y1) & (xx >= 30) & (xx <= 90)
    box = (xx >= 62) & (xx <= 80) & (yy >= 30) & (yy <= 66)
    cover = {0: disc, 1: bar}
    entry = {0: np.where(disc, 10.0, np.inf).astype(np.float32),
             1: np.where(bar, 5.0 if bar_in_front else 15.0, np.inf).astype(np.float32)}
    if cover_right:
        cover[2], entry[2] = box, np.where(box, 1.0, np.inf).astype(np.float32)
    return cover, entry


def _truth() -> np.ndarray:
    dx = [np.sqrt(R**2 - (y - CY) ** 2) for y in (Y0, Y1)]
    return np.array([[CX + dx[0], Y0], [CX + dx[1], Y1]])


def test_the_covered_outline_ends_at_the_bar():
    cover, entry = _scene()
    _, near = depth_order(entry, (S, S))
    pts, stems = pair_junctions(0, 1, cover, near)
    assert len(pts) == 2
    for t in _truth():
        d = np.linalg.norm(pts - t, axis=1)
        i = int(np.argmin(d))
        assert d[i] <= 1.5, (pts, t)
        # the disc's outline leaves the bar: upward from the top edge, downward from the bottom one
        assert abs(stems[i][1]) > 0.5 and (stems[i][1] < 0) == (t[1] < CY)


def test_the_bar_behind_the_disc_gives_the_disc_outline_over_it():
    cover, entry = _scene(bar_in_front=False)
    _, near = depth_order(entry, (S, S))
    pts, stems = pair_junctions(0, 1, cover, near)
    # now the bar's outline ends at the disc's right edge: the stems run along the bar, to the right
    assert len(pts) == 2 and np.all(stems[:, 0] > 0.8)


def test_a_nearer_third_body_hides_the_junctions_it_covers():
    cover, entry = _scene(cover_right=True)
    _, near = depth_order(entry, (S, S))
    pts, _ = pair_junctions(0, 1, cover, near)
    assert len(pts) == 0


def test_2d_stems_leave_the_front_polygon():
    t = np.linspace(0, 2 * np.pi, 96, endpoint=False)
    disc = np.stack([CX + R * np.cos(t), CY + R * np.sin(t)], 1)
    bar = np.array([[30.0, Y0], [90.0, Y0], [90.0, Y1], [30.0, Y1]])
    stems = junction_stems(disc, bar, _truth())
    assert stems[0][1] < -0.5 and stems[1][1] > 0.5
