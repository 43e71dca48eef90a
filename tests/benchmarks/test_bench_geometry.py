"""bench_geometry's odd test bed: one more T-junction on every region with an even count, mid-way along its
longest stretch without one, so that every region's cut is searched by its cusp."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from benchmarks.bench_geometry import POSE0, one_more_junction, refined_masks


def test_every_region_turns_odd_with_its_junction_in_the_longest_stretch():
    base = refined_masks(POSE0, (3, 12))
    n = len(base.boundaries[0])
    regions = [np.array([3, 12]), np.array([5]), np.zeros(0, np.int64), np.array([0, n - 1])]
    refined = one_more_junction(replace(base, boundaries=[base.boundaries[0]] * 4, junctions=regions))
    assert [len(j) % 2 for j in refined.junctions] == [1, 1, 1, 1]
    np.testing.assert_array_equal(refined.junctions[1], [5])  # odd already: untouched
    np.testing.assert_array_equal(refined.junctions[2], [0])
    # (3, 12): the stretch from 12 round to 3 is the longer one; its middle
    longest = n - 12 + 3
    np.testing.assert_array_equal(refined.junctions[0], np.unique([3, 12, (12 + longest // 2) % n]))
    # (0, n - 1): the stretch from 0 to n - 1 is the longest; its middle
    np.testing.assert_array_equal(refined.junctions[3], [0, (n - 1) // 2, n - 1])
    for jn, boundary in zip(refined.junctions, refined.boundaries):
        assert len(np.unique(jn)) == len(jn) and jn.min() >= 0 and jn.max() < len(boundary)
