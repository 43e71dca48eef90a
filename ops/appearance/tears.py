"""Where a lane tears: one warning that names the bones whose bodies the stretched pixels lie on (§5.1).

The renderer marks the visible pixels drawn by faces stretched past DISTORTION_LIMIT (DeformedSequence.distorted):
texture pulled over a gap the template holds shut, where two parts glued at the keyframe (overlapping legs, an
arm lying along the body) are pulled apart by the motion. A little of it is a limb's own bend; when a large
share of the visible character tears in one frame, the lane shows smeared webbing there and no blend can undo
it. Across the 92 lanes of the 46 evaluated shots the worst frame tears 0-59 % of the character; the three above
45 % are the two thin side walks' key1 lanes (legs overlapping at both keys, about 17 dB against the ground truth)
and realdev rd03's key1 lane (its least lane agreement, 23.1 dB). That is what the warning flags, with the fix a
person can make: the clicks or the mask that let the template part the overlap.
"""
from __future__ import annotations

import numpy as np

from ops.segmentation.skeleton_guide import bone_distance_stack
from ops.types import DeformedSequence, Skeleton
from ops.warning_subject import about

TORN_SHARE = 0.45  # a frame that draws more than this share of its visible character from torn faces is warned of
NAMED_SHARE = 0.25  # ... naming each bone nearest to at least this share of its torn pixels (the largest always)


def torn_shares(seq: DeformedSequence) -> np.ndarray:
    """(T,) float64 share of each frame's visible character (alpha > 0.5) drawn from stretched faces."""
    if seq.distorted is None:
        return np.zeros(len(seq.times))
    visible = np.maximum(1, (seq.images[..., 3] > 0.5).sum((1, 2)))
    return seq.distorted.sum((1, 2)) / visible


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
    ends = lambda pose: np.stack([pose[skeleton.bones[:, 0], :2], pose[skeleton.bones[:, 1], :2]], axis=1)
    nearest = bone_distance_stack(np.stack([xs, ys], axis=1).astype(np.float64), ends(poses[i])).argmin(axis=0)
    counts = np.bincount(nearest, minlength=len(skeleton.bones))
    named = [int(b) for b in np.argsort(-counts, kind="stable") if counts[b] >= NAMED_SHARE * len(xs)]
    named = named or [int(np.argmax(counts))]
    names = tuple(f"{skeleton.joints[skeleton.bones[b, 0]]}-{skeleton.joints[skeleton.bones[b, 1]]}" for b in named)
    at = ends(key_pose)[named].reshape(-1, 2).mean(axis=0)
    one = len(names) == 1
    return about("bone" if one else "bones",
                 f"key{key}'s lane draws {shares[i]:.0%} of the character from stretched triangles at "
                 f"t = {seq.times[i]:.2f} (frame {i}), most of it along "
                 + ("this bone: the template keeps its part glued to what it overlaps or touches in "
                    f"key{key}, and the motion pulls them apart" if one else
                    f"these bones: the template keeps their parts glued together as in key{key}, and the motion "
                    "pulls them apart"),
                 name=names[0] if one else names, at=at,
                 fix=f"where they overlap or touch in key{key}, click the T-junctions or paint an occlusion mask "
                     "(the deformed_frames preview tints the stretched pixels red)")
