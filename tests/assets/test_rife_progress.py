"""rife_matrix's progress events: one per batch of RIFE blends, counting up to the blends the matrix took, never
past the bound it announces (the alpha-1/2 cell of every time, then depth - 1 cells per time at most)."""
from __future__ import annotations

import numpy as np
import pytest

from assets import progress
from assets.blending import _CountedRife
from ops.blending.image_matrix import alpha_grid, build_image_matrix
from tests.ops.blending.test_image_matrix import AveragingFake, random_frames


@pytest.mark.parametrize("deepest", [False, True])
def test_progress_counts_every_blend_up_to_the_bound(deepest):
    T, depth = 7, 3
    n_a = len(alpha_grid(depth))
    rng = np.random.default_rng(1)
    # the path's alpha index per time: random, or every time at a deepest-level cell (odd index: the worst case)
    chosen = rng.choice(np.arange(1, n_a, 2), T) if deepest else rng.integers(0, n_a, T)

    def wanted(flows):
        cells = np.zeros((T, n_a), bool)
        cells[np.arange(T), chosen] = True
        return cells

    events = []
    fake = AveragingFake()
    rife = _CountedRife(fake, "shot", "seg0/rife_matrix", T * depth)
    with progress.listen(events.append):
        matrix = build_image_matrix(random_frames(T), random_frames(T, seed=2), np.linspace(0, 1, T), rife,
                                    depth=depth, batch=2, wanted=wanted)
    blends = int(matrix.computed[:, 1:-1].sum())  # what the stage's metadata calls its inferences
    counts = [e["done"] for e in events]
    assert all(e["stage"] == "seg0/rife_matrix" and e["event"] == "progress" and e["bound"] == T * depth for e in events)
    # rows are filled on several threads: each event adds one call's pairs, in whichever order they finished
    assert sorted(np.diff([0, *counts]).tolist()) == sorted(fake.calls) and counts[-1] == blends <= T * depth
    if deepest:
        assert blends == T * depth  # the bound is reached: it is the least upper bound
    assert rife.device == fake.device  # everything else is the network's own


def test_scaled_cells_count_one_call_a_time():
    """With scaled cells the network runs at alpha 1/2 only: the progress counts one blend per time, up to the
    bound T the stage announces for them."""
    T, depth = 5, 3
    events = []
    fake = AveragingFake()
    rife = _CountedRife(fake, "shot", "seg0/rife_matrix", T)
    pick = np.zeros((T, len(alpha_grid(depth))), bool)
    pick[:, 1] = True  # every time at the first eighth: three calls each by bisection
    with progress.listen(events.append):
        build_image_matrix(random_frames(T), random_frames(T, seed=2), np.linspace(0, 1, T), rife, depth=depth,
                           wanted=lambda flows: pick, cells="scaled")
    assert [e["done"] for e in events][-1] == rife.done == sum(fake.calls) == T
