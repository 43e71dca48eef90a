"""Texture and interpolation quality of the image matrix cells (§5.2).

Texture quality q(t, alpha) measures how much of a blended frame's character
comes from inpainted texture (and, our extension, from texture distorted
beyond a limit by a tearing mesh); interpolation quality Q(t) measures how hard
the RIFE flow at time t is, as the integral of its squared divergence
(flows that stretch or squash regions, rather than translate or shear them,
are where frame interpolation produces ghosting).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ops.types import DeformedSequence

if TYPE_CHECKING:
    import pandas as pd


def inpainted_share(inpainted: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """inpainted: (T, H, W) bool, alpha: (T, H, W) float32 coverage -> (T,) float64 share in [0, 1]."""
    inpainted = np.asarray(inpainted, dtype=bool)
    alpha = np.asarray(alpha, dtype=np.float64)
    if inpainted.shape != alpha.shape or inpainted.ndim != 3:
        raise ValueError(f"inpainted {inpainted.shape} and alpha {alpha.shape} must both be (T, H, W)")
    covered = alpha.sum(axis=(1, 2))
    dirty = np.where(inpainted, alpha, 0.0).sum(axis=(1, 2))
    # An empty frame shows no texture at all, so none of it is inpainted.
    return np.divide(dirty, covered, out=np.zeros_like(covered), where=covered > 0)


def unreliable_pixels(seq: DeformedSequence) -> np.ndarray:
    """(T, H, W) bool: each frame's visible texture that is not the drawing as drawn: inpainted (the paper's q), or
    drawn by faces distorted beyond the renderer's limit, where a mesh glued across an occlusion that the masks
    missed tears and smears (our extension: without it, the path takes a torn lane whose pockets happen to need
    no inpainting)."""
    return seq.inpainted if seq.distorted is None else seq.inpainted | seq.distorted


def unreliable_share(seq: DeformedSequence) -> np.ndarray:
    """(T,) share of each frame's visible character whose texture is unreliable (unreliable_pixels)."""
    return inpainted_share(unreliable_pixels(seq), seq.images[..., 3])


def texture_quality(share0: np.ndarray, share1: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """share0, share1: (T,) inpainted shares of the two sequences, alphas: (A,) -> (T, A) cost q."""
    s0 = np.asarray(share0, dtype=np.float64)[:, None]
    s1 = np.asarray(share1, dtype=np.float64)[:, None]
    a = np.asarray(alphas, dtype=np.float64)[None, :]
    if s0.shape != s1.shape:
        raise ValueError(f"share0 {s0.shape[:1]} and share1 {s1.shape[:1]} must have the same length")
    return (1.0 - a) * s0 + a * s1


def flow_divergence(flow: np.ndarray) -> np.ndarray:
    """flow: (H, W, 2) pixels, (u = x along columns, v = y along rows) -> (H, W) float64 du/dx + dv/dy."""
    flow = np.asarray(flow, dtype=np.float64)
    if flow.ndim != 3 or flow.shape[2] != 2:
        raise ValueError(f"flow must be (H, W, 2), got {flow.shape}")
    # x runs along axis 1 (columns), y along axis 0 (rows): differentiating the
    # other way round would report shears as expansions.
    du_dx = np.gradient(flow[..., 0], axis=1)
    dv_dy = np.gradient(flow[..., 1], axis=0)
    return du_dx + dv_dy


def interpolation_quality(flows: np.ndarray, weight: np.ndarray | None = None) -> np.ndarray:
    """flows: (T, H, W, 4) RIFE flows at alpha 1/2, weight: (T, H, W) or None -> (T,) float64 Q(t).

    Q(t) = integral of |div v|^2 over the image taken as the unit square, i.e. the pixel sum / (H W):
    div v is scale-free, so Q does not grow with the resolution of the shot.
    """
    flows = np.asarray(flows)
    if flows.ndim != 4 or flows.shape[3] != 4:
        raise ValueError(f"flows must be (T, H, W, 4), got {flows.shape}")
    if weight is not None and np.shape(weight) != flows.shape[:3]:
        raise ValueError(f"weight {np.shape(weight)} must be (T, H, W) = {flows.shape[:3]}")
    out = np.empty(flows.shape[0], dtype=np.float64)
    for t in range(flows.shape[0]):  # one frame at a time: flows may be a large memmap
        d2 = flow_divergence(flows[t, ..., 0:2]) ** 2 + flow_divergence(flows[t, ..., 2:4]) ** 2
        if weight is not None:
            d2 = d2 * np.asarray(weight[t], dtype=np.float64)
        out[t] = d2.sum() / d2.size
    return out


def coverage_weight(alpha0: np.ndarray, alpha1: np.ndarray) -> np.ndarray:
    """alpha0, alpha1: (T, H, W) coverage of the two sequences -> (T, H, W) bool where either covers."""
    return (np.asarray(alpha0) > 0) | (np.asarray(alpha1) > 0)


def quality_inputs(seq0: DeformedSequence, seq1: DeformedSequence, alphas: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(unreliable-texture shares (T,) of both sequences, q (T, A) at alphas (A,), the coverage weight
    (T, H, W) of Q): what the path's costs need of the two deformed sequences."""
    share0, share1 = unreliable_share(seq0), unreliable_share(seq1)
    weight = coverage_weight(seq0.images[..., 3], seq1.images[..., 3])
    return share0, share1, texture_quality(share0, share1, alphas), weight


def quality_table(times: np.ndarray, alphas: np.ndarray, q: np.ndarray, Q: np.ndarray) -> pd.DataFrame:
    """times: (T,), alphas: (A,), q: (T, A), Q: (T,) -> long DataFrame (t, alpha, q, Q), T * A rows, t-major."""
    times = np.asarray(times, dtype=np.float64)
    alphas = np.asarray(alphas, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    Q = np.asarray(Q, dtype=np.float64)
    n_t, n_a = len(times), len(alphas)
    if q.shape != (n_t, n_a) or Q.shape != (n_t,):
        raise ValueError(f"q {q.shape} must be (T, A) = {(n_t, n_a)} and Q {Q.shape} must be (T,)")
    import pandas as pd  # imported where a table is built: importing this module stays cheap (0.3 s less)

    return pd.DataFrame({
        "t": np.repeat(times, n_a),
        "alpha": np.tile(alphas, n_t),
        "q": q.reshape(-1),
        "Q": np.repeat(Q, n_a),
    })
