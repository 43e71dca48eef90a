"""What a lane's own frames say about it, with no ground truth: where it tears, and where it misses the other key.

Each check gives one warning at most, naming the bones the trouble lies along (their middle at the lane's own
key, in keyframe pixels, where a person makes the fix), so that a batch's bad shots say so without anyone
opening every preview.

- **Tears.** The renderer marks the visible pixels drawn by faces stretched past DISTORTION_LIMIT
  (DeformedSequence.distorted): texture pulled over a gap the template holds shut, where two parts glued at the
  keyframe (overlapping legs, an arm lying along the body) are pulled apart by the motion. A little of it is a
  limb's own bend; when a large share of the visible character tears in one frame, the lane shows smeared
  webbing there and no blend can undo it. Across the 92 lanes of the 46 evaluated shots the worst frame tears
  0-57 % of the character; the three above TORN_SHARE are the two thin side walks' key1 lanes (legs overlapping
  at both keys, about 17 dB against the ground truth) and realdev rd03's key1 lane (its least lane agreement).
- **Disagreement.** A lane deformed to the other key's pose should look like that key's drawing (lane
  agreement, docs/lanes.md). On the 46 evaluated shots it is 20.5-41 dB; below AGREE_DB are only the two thin
  side walks. A joint put on the wrong limb in one key (arm_cross with key1's forearms swapped left for right:
  28.8 / 31.1 -> 20.4 / 18.8 dB) falls there too, which no other check names as a pose error.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from ops.blending.quality import inpainted_share
from ops.evaluation.plate import over
from ops.evaluation.psnr import psnr
from ops.segmentation.skeleton_guide import bone_distance_stack
from ops.types import DeformedSequence, Masks, Skeleton
from ops.warning_subject import about

TORN_SHARE = 0.45  # a frame that draws more than this share of its visible character from torn faces is warned of
AGREE_DB = 21.0  # a lane further than this from the other key's drawing at that key's pose is warned of
NAMED_SHARE = 0.25  # a warning names each bone nearest to at least this share of its pixels (the largest always)
HOT_SIGMA = 3.0  # px: the difference is blurred so that a misplaced part reads as one area, not its outlines
HOT_SHARE = 0.5  # ... and the pixels within this share of its largest value are where it lies


def _along(pixels: np.ndarray, pose: np.ndarray, own_pose: np.ndarray, skeleton: Skeleton
           ) -> tuple[str | tuple[str, ...], np.ndarray, bool]:
    """The bones (N, 2) pixels (x, y) at `pose` lie nearest to: (a name or several, their middle at own_pose, one)."""
    nearest = bone_distance_stack(pixels.astype(np.float64), pose[:, :2][skeleton.bones]).argmin(axis=0)
    counts = np.bincount(nearest, minlength=len(skeleton.bones))
    named = [int(b) for b in np.argsort(-counts, kind="stable") if counts[b] >= NAMED_SHARE * len(pixels)]
    named = named or [int(np.argmax(counts))]
    names = tuple(f"{skeleton.joints[skeleton.bones[b, 0]]}-{skeleton.joints[skeleton.bones[b, 1]]}" for b in named)
    at = own_pose[:, :2][skeleton.bones[named]].reshape(-1, 2).mean(axis=0)
    return (names[0] if len(names) == 1 else names), at, len(names) == 1


def torn_shares(seq: DeformedSequence) -> np.ndarray:
    """(T,) float64 share of each frame's visible character (its coverage) drawn from stretched faces, as q
    counts shares (ops.blending.quality.inpainted_share)."""
    if seq.distorted is None:
        return np.zeros(len(seq.times))
    return inpainted_share(seq.distorted, seq.images[..., 3])


def torn_warning(seq: DeformedSequence, poses: np.ndarray, key_pose: np.ndarray, skeleton: Skeleton,
                 key: int) -> str | None:
    """The warning for the lane's worst frame when it tears more than TORN_SHARE of the character, else None.

    poses: (T, J, 3) the segment's poses, pixels, one per frame of seq; key_pose: (J, 3) the lane's own key's
    pose: the warning sits at the named bones' middle there, in keyframe pixels, where a person clicks the fix.
    """
    shares = torn_shares(seq)
    if len(shares) == 0 or shares.max() <= TORN_SHARE:
        return None
    i = int(np.argmax(shares))
    ys, xs = np.nonzero(seq.distorted[i])
    name, at, one = _along(np.stack([xs, ys], axis=1), poses[i], key_pose, skeleton)
    return about("bone" if one else "bones",
                 f"key{key}'s lane draws {shares[i]:.0%} of the character from stretched triangles at "
                 f"t = {seq.times[i]:.2f} (frame {i}), most of it along "
                 + ("this bone: the template keeps its part glued to what it overlaps or touches in "
                    f"key{key}, and the motion pulls them apart" if one else
                    f"these bones: the template keeps their parts glued together as in key{key}, and the motion "
                    "pulls them apart"),
                 name=name, at=at,
                 fix=f"where they overlap or touch in key{key}, click the T-junctions or paint an occlusion mask "
                     "(the deformed_frames preview tints the stretched pixels red); if the joints here sit on "
                     "other parts in the other key, move them")


def agreement(at_other: np.ndarray, other: Masks) -> tuple[float, np.ndarray]:
    """(PSNR dB, (H, W) float64 per-pixel difference) of a lane's frame (H, W, 4) at the other key's pose against
    that key's drawing as its masks hold it (coverage, colour and paper: the drawing, unmixed), over its paper."""
    cov = np.asarray(other.coverage, np.float32)[..., None]
    want = cov * other.colour + (1.0 - cov) * other.paper
    got = over(at_other[None], other.paper)[0]
    return psnr(got, want), np.abs(got - want).mean(axis=-1)


def agreement_warning(db: float, difference: np.ndarray, other_pose: np.ndarray, own_pose: np.ndarray,
                      skeleton: Skeleton, key: int, other: int) -> str | None:
    """The warning for a lane whose agreement `db` with key `other`'s drawing is under AGREE_DB, else None;
    difference: (H, W) its per-pixel difference (`agreement`), at other_pose (J, 3); own_pose: (J, 3) key's."""
    if not db < AGREE_DB:
        return None
    hot = ndimage.gaussian_filter(difference, HOT_SIGMA)
    ys, xs = np.nonzero(hot >= HOT_SHARE * hot.max())
    name, at, one = _along(np.stack([xs, ys], axis=1), other_pose, own_pose, skeleton)
    return about("bone" if one else "bones",
                 f"key{key}'s lane, deformed to key{other}'s pose, is {db:.1f} dB from key{other}'s drawing, most "
                 f"of the difference along {'this bone' if one else 'these bones'}: the two keys differ here "
                 "beyond what the skeleton explains",
                 name=name, at=at,
                 fix=f"check that these joints sit on the same parts of the drawing in key{key} and key{other} (a "
                     "left/right mix-up, a joint on the wrong limb); where a part is redrawn or the parts overlap, "
                     "click the T-junctions or paint an occlusion mask")
