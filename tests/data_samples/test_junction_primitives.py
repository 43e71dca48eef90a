"""Plain geometric drawings for the junction network: their T-junctions are exact, their stems leave the front
shape along the back outline, their texture strokes touch no outline, and they are reproducible."""
from __future__ import annotations

import cv2
import numpy as np

from data_samples.generator.junction_primitives import make_primitive

N = 120


def _distance_to_outline(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    a, b = poly, np.roll(poly, -1, 0)
    ab = b - a
    t = np.clip(((pts[:, None] - a[None]) * ab[None]).sum(-1) / np.maximum((ab**2).sum(-1), 1e-12)[None], 0, 1)
    return np.linalg.norm(pts[:, None] - (a[None] + t[..., None] * ab[None]), axis=2).min(1)


def _signed_outside(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    p = poly.astype(np.float32)
    return np.array([-cv2.pointPolygonTest(p, (float(x), float(y)), True) for x, y in pts])


def test_junctions_lie_on_both_outlines_and_come_in_pairs():
    counts = []
    for i in range(N):
        s = make_primitive(i)
        pts = np.asarray(s["pairs"][0]["t_junctions"]).reshape(-1, 2)
        counts.append(len(pts))
        if len(pts):
            assert _distance_to_outline(s["back_outline"], pts).max() < 1e-6
            assert _distance_to_outline(s["front_outline"], pts).max() < 1e-6
        # two closed outlines in general position cross an even number of times
        assert len(pts) % 2 == 0, (i, len(pts))
    counts = np.array(counts)
    assert (counts == 0).mean() < 0.25 and (counts >= 2).mean() > 0.75  # mostly crossings, some patches


def test_stems_run_along_the_back_outline_out_of_the_front_shape():
    for i in range(N):
        s = make_primitive(i)
        pts = np.asarray(s["pairs"][0]["t_junctions"]).reshape(-1, 2)
        stems = np.asarray(s["pairs"][0]["t_stems"]).reshape(-1, 2)
        if not len(pts):
            continue
        assert np.allclose(np.linalg.norm(stems, axis=1), 1.0)
        ahead = pts + 3.0 * stems
        assert (_distance_to_outline(s["back_outline"], ahead) < 1.0).all()
        assert (_signed_outside(s["front_outline"], ahead) > 0.5).all(), i


def test_texture_strokes_touch_no_outline_and_the_front_bone_is_nearer():
    seen = 0
    for i in range(N):
        s = make_primitive(i)
        for a, b in s["strokes"]:
            along = a + np.linspace(0, 1, 40)[:, None] * (b - a)
            assert _distance_to_outline(s["back_outline"], along).min() > 6.0
            assert _signed_outside(s["front_outline"], along).min() > 7.0
            seen += 1
        assert (s["pose"][2:, 2] < s["pose"][:2, 2]).all()
        h, w = s["image"].shape[:2]
        assert s["fg"].shape == (h, w) and max(h, w) <= 256
        assert (s["fg"][np.round(s["back_outline"][:, 1]).astype(int).clip(0, h - 1),
                        np.round(s["back_outline"][:, 0]).astype(int).clip(0, w - 1)] > 100).all()
    assert seen > N // 2


def test_the_same_index_draws_the_same_sample():
    a, b, c = make_primitive(7), make_primitive(7), make_primitive(8)
    assert np.array_equal(a["image"], b["image"]) and a["pairs"] == b["pairs"]
    assert a["image"].shape != c["image"].shape or not np.array_equal(a["image"], c["image"])
