"""bench_path's q of the frames the per-pixel alpha makes: at strength 0 it is the run's q, and where one lane's
texture is unreliable and the other's is good, moving alpha per pixel lowers it below the run's."""
from __future__ import annotations

import numpy as np

from benchmarks.bench_path import local_texture_quality
from ops.blending.quality import texture_quality, unreliable_share
from ops.types import DeformedSequence

T, H, W = 3, 40, 48
ALPHAS = np.linspace(0.0, 1.0, 5)


def lane(bad: tuple[slice, slice] | None, seed: int) -> DeformedSequence:
    """A lane of T frames whose character (a soft-edged box) is unreliable in `bad` (inpainted on frame 1,
    distorted on frame 2)."""
    rng = np.random.default_rng(seed)
    images = np.zeros((T, H, W, 4), np.float32)
    images[..., :3] = rng.random((T, H, W, 3))
    images[:, 6:34, 8:40, 3] = 1.0
    images[:, 5, 8:40, 3] = 0.5  # a soft rim: coverage weighs the shares
    inpainted, distorted = np.zeros((T, H, W), bool), np.zeros((T, H, W), bool)
    if bad is not None:
        inpainted[1][bad] = True
        distorted[2][bad] = True
    return DeformedSequence(times=np.linspace(0, 1, T), vertices=np.zeros((T, 3, 2)), images=images,
                            inpainted=inpainted, energies=np.zeros(T), iterations=np.zeros(T, np.int64),
                            distorted=distorted)


def test_strength_zero_is_the_runs_q():
    seq0, seq1 = lane((slice(10, 20), slice(10, 22)), 0), lane((slice(20, 30), slice(25, 38)), 1)
    want = texture_quality(unreliable_share(seq0), unreliable_share(seq1), ALPHAS)
    np.testing.assert_allclose(local_texture_quality(seq0, seq1, ALPHAS, 0.0), want, atol=1e-12)


def test_per_pixel_alpha_takes_the_other_lanes_good_texture():
    seq0, seq1 = lane((slice(10, 20), slice(10, 22)), 0), lane(None, 1)  # only lane 0 is unreliable, in one patch
    run = texture_quality(unreliable_share(seq0), unreliable_share(seq1), ALPHAS)
    local = local_texture_quality(seq0, seq1, ALPHAS, 2.0)
    assert np.all(local <= run + 1e-12)
    inner = ALPHAS < 1.0  # at alpha 1 the frame is lane 1's already, which is clean
    assert np.all(local[1:, inner] < run[1:, inner])  # frames 1 and 2 carry the patch: the per-pixel alpha clears it
    np.testing.assert_array_equal(local[0], 0.0)  # frame 0 is clean in both lanes
