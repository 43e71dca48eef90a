"""Where neither lane's texture can be trusted, the keys' own interpolation.

The per-pixel alpha (ops/blending/local_alpha.py) takes each part of a frame from the lane whose texture is
reliable there. Where both lanes are unreliable at once (both tear across an overlap the masks missed, or one
tears where the other is inpainted), it has nothing to choose, and the frame shows the smear. RIFE applied to
the two keys alone ghosts there instead of smearing, which is nearer the drawing: each interior frame takes it
with the weight

    w(x) = max(min(b0(x), b1(x)), blur(m)(x)),

b0, b1 the lanes' unreliable masks u0, u1 (what q counts) blurred over FALLBACK_SIGMA px, blended premultiplied
(so that over any paper the result is (1 - w) of the frame's composite plus w of RIFE's). The second term is
where the two lanes' tears meet: each lane tears its own copy of a moving part, and the copies lie apart (r08's
forearms unfolding: key0's lane streaks them across the chest while key1's fans them out at the shoulders). At a
pixel only one lane tears, the per-pixel alpha takes the other, which is reliable there but draws the part
elsewhere, so the part drops out of the frame. m is therefore both lanes' unreliable pixels (u0 | u1) within
FALLBACK_SIGMA px of where min(b0, b1) reaches MEET_DENSITY: there both tears come from the keys' interpolation,
which ghosts the part rather than dropping it. A lane that tears alone, far from the other's tears, keeps the
per-pixel alpha's choice. RIFE ghosts badly too where the keys lie too far apart for its flow (a foot a stride
away): there its two warped keys disagree while its fusion weighs both, and the meeting term leaves those pixels
(within GHOST_SIGMA px) to the lanes.

The keys interpolated are the lanes' own first and last frames, the characters alone (alpha = coverage), as every
lane is, by one network call at 1/2 whose flows are scaled to each time (the image matrix's scaled cells), on the
box around every weighted pixel with CONTEXT_PX of context. A segment where no frame's weights sum to MIN_SHARE of
the frame calls no network and is returned as it was; the keys are never changed.
"""
from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from ops.blending.crop import Box, coverage_box
from ops.blending.image_matrix import alpha_grid, build_image_matrix
from ops.blending.quality import unreliable_pixels
from ops.blending.rife_onnx import scaled_flow_mask, warp
from ops.types import DeformedSequence

FALLBACK_SIGMA = 6.0  # px (twice the per-pixel alpha's): chosen on the held-out sets too, docs/method.md
MIN_WEIGHT = 1.0 / 255  # a frame whose weight stays below this everywhere is left as it is
# the network is called for a segment only where some frame's weights sum to this share of the frame: below it the
# samples gained at most 0.03 dB (arm_cross, 0.16e-3 of its frame at most), and the call and the network's load
# are not worth it
MIN_SHARE = 5e-4
MAX_DEPTH = 3  # the keys' alpha grid at most 9 values (other times take the nearest); one network call, at 1/2
# the two lanes' tears meet where both blurred unreliable masks reach this (3 % of the kernel's mass: a few torn pixels
# of each lane within a sigma of one another); chosen on the held-out sets too (docs/method.md)
MEET_DENSITY = 0.03
# the keys are interpolated on the box around the weighted pixels grown by this (snapped to RIFE's 32 px grid): room
# for the flows of a part that the keys draw apart (r08's forearms move 40-50 px) and for the network's borders;
# the whole frame cost arm_cross's frames stage 0.3 s of its 0.6
CONTEXT_PX = 64
# RIFE ghosts where its two warped keys differ by this much (premultiplied, in any channel) while its fusion mask
# weighs both alike; the meeting term keeps off such pixels blurred over GHOST_SIGMA px. Chosen with the meeting's
# density on every evaluated set (docs/method.md): the walks' feet stop being ghosted
GHOST_DIFF = 0.3
GHOST_SIGMA = 3.0


def dyadic_depth(times: np.ndarray, max_depth: int = 6) -> int:
    """Smallest bisection depth whose grid holds every t (else max_depth, nearest alpha used)."""
    for d in range(1, max_depth + 1):
        scaled = np.asarray(times) * 2**d
        if np.allclose(scaled, np.round(scaled), atol=1e-9):
            return d
    return max_depth


def _keys_matrix(key0: np.ndarray, key1: np.ndarray, times: np.ndarray, rife, max_depth: int, cells: str):
    """The one-row image matrix between two keys (H, W, 4) and, per t of times (T,), the index (T,) of its alpha
    (the grid's nearest)."""
    depth = dyadic_depth(times, max_depth)
    m = build_image_matrix(key0[None], key1[None], np.zeros(1), rife, depth=depth, cells=cells)
    grid = alpha_grid(depth)
    return m, np.abs(grid[None, :] - np.asarray(times)[:, None]).argmin(1)


def interpolate_keys(key0: np.ndarray, key1: np.ndarray, times: np.ndarray, rife, max_depth: int = 6,
                     cells: str = "bisection") -> np.ndarray:
    """RIFE between two keys (H, W, 4) to each t of times (T,) -> (T, H, W, 4) float32 (the grid's nearest alpha
    where a t is not on a dyadic grid of depth max_depth or less). cells: "bisection" (recursive midpoints, RIFE
    as it is used on its own) or "scaled" (one network call at 1/2, its flows scaled to each t, as the image
    matrix's cells: ops/blending/image_matrix.py)."""
    m, idx = _keys_matrix(key0, key1, times, rife, max_depth, cells)
    return m.frames[0, idx].astype(np.float32)


def ghosting(key0: np.ndarray, key1: np.ndarray, flow: np.ndarray, mask: np.ndarray, alpha: float) -> np.ndarray:
    """(H, W) float32: how much RIFE's frame at alpha, from the keys (H, W, 4) straight RGBA, their midpoint's
    flow (H, W, 4) px and fusion mask (H, W) (the weight of key0), ghosts: the largest channel difference of the
    two keys warped there (premultiplied, by RIFE's own blend's warp), times 4 m (1 - m) of the mask at alpha (1
    where both weigh alike, 0 where one key alone is taken)."""
    return _ghosting(_premultiplied(key0), _premultiplied(key1), flow, mask, alpha)


def _premultiplied(key: np.ndarray) -> np.ndarray:
    """(H, W, 4) straight RGBA -> (1, 4, H, W) premultiplied, as RIFE's warp takes it."""
    return np.concatenate((key[..., :3] * key[..., 3:], key[..., 3:]), -1).transpose(2, 0, 1)[None]


def _ghosting(pre0: np.ndarray, pre1: np.ndarray, flow: np.ndarray, mask: np.ndarray, alpha: float) -> np.ndarray:
    """ghosting from the keys already premultiplied (_premultiplied): a segment's frames share them."""
    f, m = scaled_flow_mask(np.asarray(flow, np.float32).transpose(2, 0, 1)[None],
                            np.asarray(mask, np.float32)[None, None], float(alpha))
    diff = np.abs(warp(pre0, f[:, :2]) - warp(pre1, f[:, 2:4])).max(1)[0]
    m = m[0, 0]
    return (diff * 4.0 * m * (1.0 - m)).astype(np.float32)


def _blur(mask: np.ndarray, sigma: float) -> np.ndarray:
    """(H, W) bool -> (H, W) float32 blurred over sigma px, the kernel cut at 3 sigma."""
    size = 2 * int(np.ceil(3 * sigma)) + 1
    return cv2.GaussianBlur(mask.astype(np.float32), (size, size), sigma)


def _weight_terms(unreliable0: np.ndarray, unreliable1: np.ndarray, sigma: float, meet: float
                  ) -> tuple[np.ndarray, np.ndarray | None]:
    """fallback_weight's two (H, W) float32 terms: the lesser blurred mask, and the tears that meet (None where
    they do not)."""
    b0, b1 = _blur(unreliable0, sigma), _blur(unreliable1, sigma)
    lesser = np.minimum(b0, b1)
    meeting = lesser >= meet
    if not meeting.any():
        return lesser, None
    reach = 2 * int(np.ceil(sigma)) + 1
    near = cv2.dilate(meeting.astype(np.uint8), np.ones((reach, reach), np.uint8)) > 0
    return lesser, _blur((unreliable0 | unreliable1) & near, sigma)


def fallback_weight(unreliable0: np.ndarray, unreliable1: np.ndarray, sigma: float = FALLBACK_SIGMA,
                    meet: float = MEET_DENSITY) -> np.ndarray:
    """(H, W) float32 in [0, 1] from the lanes' (H, W) bool unreliable masks: the lesser of the two blurred over
    sigma px, and, where the two blurred masks both reach `meet`, both lanes' unreliable pixels within sigma px of
    there, blurred (module docstring; before RIFE's ghosts are kept off). 0 wherever neither lane is unreliable
    within 3 sigma, and where one lane is unreliable alone with no pixel of the other's within 7 sigma."""
    return _combined(*_weight_terms(unreliable0, unreliable1, sigma, meet))


def _combined(lesser: np.ndarray, meeting: np.ndarray | None) -> np.ndarray:
    """The weight from _weight_terms' two terms, before RIFE's ghosts are kept off."""
    return lesser if meeting is None else np.maximum(lesser, meeting)


def mix_premultiplied(frame: np.ndarray, other: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """(H, W, 4) straight-alpha frame with `weight` (H, W) of the straight-alpha `other` blended in, premultiplied:
    composited over any paper, (1 - w) frame's composite + w other's."""
    w = weight[..., None].astype(np.float32)
    a = (1.0 - w) * frame[..., 3:] + w * other[..., 3:]
    rgb = (1.0 - w) * frame[..., :3] * frame[..., 3:] + w * other[..., :3] * other[..., 3:]
    out = np.array(frame, np.float32)
    np.divide(rgb, a, out=out[..., :3], where=a > 0)
    out[..., 3:] = a
    return np.clip(out, 0.0, 1.0)


def with_key_fallback(frames: np.ndarray, seq0: DeformedSequence, seq1: DeformedSequence, times: np.ndarray,
                      load_rife: Callable[[], object], sigma: float = FALLBACK_SIGMA,
                      context: int | None = CONTEXT_PX) -> tuple[np.ndarray, np.ndarray]:
    """The segment's frames (T, H, W, 4) with every interior frame's doubly unreliable pixels, and the tears of
    either lane where they meet the other's, taken from RIFE's interpolation of the keys (module docstring); times
    (T,) the segment's, 0 .. 1. The keys are interpolated on the box around every weighted pixel grown by `context`
    px (None: the whole frame). Returns the frames and their weights (T, H, W) float32 in [0, 1] (0 at the keys and
    wherever the frame was left as it was; what the stage's preview tints). load_rife() gives the network, called
    only where some frame's weights sum to MIN_SHARE of the frame."""
    out = np.array(frames, np.float32)
    weights_out = np.zeros(out.shape[:3], np.float32)
    u0, u1 = unreliable_pixels(seq0), unreliable_pixels(seq1)
    terms = {t: _weight_terms(u0[t], u1[t], sigma, MEET_DENSITY) for t in range(1, len(frames) - 1)}
    weights = {t: _combined(*terms[t]) for t in terms}
    weights = {t: w for t, w in weights.items() if w.max() >= MIN_WEIGHT}
    if not weights or max(float(w.sum()) for w in weights.values()) < MIN_SHARE * out[0, ..., 0].size:
        return out, weights_out
    shape = out.shape[1:3]
    box = Box(0, shape[0], 0, shape[1]) if context is None else \
        coverage_box(np.stack([w > 0 for w in weights.values()]), margin=context)
    ys, xs = box.slices
    key0 = np.ascontiguousarray(seq0.images[0][ys, xs], np.float32)
    key1 = np.ascontiguousarray(seq1.images[-1][ys, xs], np.float32)
    m, idx = _keys_matrix(key0, key1, times, load_rife(), MAX_DEPTH, "scaled")
    pre0, pre1 = _premultiplied(key0), _premultiplied(key1)  # once for every frame's ghost test
    for t in weights:
        lesser, meeting = (term[ys, xs] if term is not None else None for term in terms[t])
        w = lesser
        if meeting is not None:  # the tears that meet, less where RIFE itself ghosts
            ghost = _ghosting(pre0, pre1, m.flows[0], m.masks[0], m.alphas[idx[t]]) >= GHOST_DIFF
            w = np.maximum(lesser, meeting * (1.0 - np.minimum(_blur(ghost, GHOST_SIGMA), 1.0)))
        window = out[t][ys, xs]
        touched = w > 0  # elsewhere the frame stays bit for bit (and every weighted pixel is in the box)
        window[touched] = mix_premultiplied(window, m.frames[0, idx[t]].astype(np.float32), w)[touched]
        weights_out[t][ys, xs] = w
    return out, weights_out
