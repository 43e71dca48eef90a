"""Lanes that agree: register a lane's mesh, deformed to the other key's pose, onto the other key's drawing.

The skeleton explains most of the change from one key to the next; what it does not (a redrawn hand, a sleeve
drawn wider, a limb bent a little off its bones) leaves the lane a few pixels off the other drawing where the
segment ends. Here a dense optical flow (OpenCV DIS) from the lane's rendering to the drawing, both over
white, is sampled at the visible vertices, trusted where it is forward-backward consistent, and turned into a
per-vertex displacement D (V, 2) px by minimizing

    E(Y) = SD(Y; rest X) + stiffness * sum_v c_v m_v |Y_v - (X_v + flow(X_v))|^2

from Y = X with the injective deformer (ops.geometry.deform: no iterate folds a triangle), in a few passes
(render where the last pass left the mesh, flow again, solve on). The distortion is measured against the
deformed mesh X itself, so where the rendering already agrees (flow 0) D stays 0; c_v is the flow's trust
(consistent, on a visible vertex, short), m_v the lumped vertex areas (sum 1, so the weight does not depend on
the mesh's resolution).

fade_in then applies D over the segment: the frame at progress u (0 at the lane's own key, 1 at the other)
moves by ease(u) D, turned with the mesh's local rotation from the other key's frame to this one, capped per
frame by the injectivity bound (max_injective_step), so no frame folds and the own key's frame (u = 0) is left
untouched, bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ops.geometry.deform import Deformer, max_injective_step
from ops.geometry.mesh import signed_areas

# data weight, normalized units. The flow is smoothed by the forward-backward check and the trust, not by the
# distortion term: on the samples' lanes 3e3 (smoothing over ~5% of the character) reached 1.6 dB of agreement,
# 1e6 3.5 dB (seq_arm_cross), with no fold (the barrier holds at any weight)
STIFFNESS = 1e6
GRAD_TOL = 1e-3  # normalized gradient norm; 1e-2 stops after 3-5 iterations, 0.5 dB short
PASSES = 5  # render, flow, solve; a stroke a few pixels off is found in full only once it is near (3: -0.3 dB)
CONSISTENCY_PX = 1.5  # forward-backward flow error at which a vertex's trust falls to 1/e
MAX_SHIFT = 0.15  # flows longer than this share of the character's size are not trusted (not a local change)
FLOW_BLUR = 1.5  # Gaussian sigma, px, of both images before the flow: 1-2 px wide strokes overlap again (+0.5 dB)


@dataclass
class Registration:
    """Displacement of a deformed mesh onto another drawing."""

    displacement: np.ndarray  # (V, 2) float64 px, X + displacement is fold-free
    trust: np.ndarray  # (V,) float64 in [0, 1]: the data term's weight of each vertex (0: not seen, inconsistent)
    flow_at_vertices: np.ndarray  # (V, 2) float64 px: the flow sampled at each vertex
    iterations: int


def gray_over_white(rgba: np.ndarray) -> np.ndarray:
    """(H, W, 4) straight-alpha float RGBA in [0, 1] -> (H, W) uint8 luminance composited over white."""
    a = np.clip(rgba[..., 3:4], 0.0, 1.0)
    rgb = np.clip(rgba[..., :3], 0.0, 1.0) * a + (1.0 - a)
    lum = rgb @ np.array([0.299, 0.587, 0.114])
    return np.clip(lum * 255.0 + 0.5, 0, 255).astype(np.uint8)


def dense_flow(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """(H, W, 2) float32 DIS flow f with src(x) ~ dst(x + f(x)), both (H, W) uint8, after a FLOW_BLUR blur."""
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)  # FAST: 1.3 dB less on seq_arm_cross
    src, dst = cv2.GaussianBlur(src, (0, 0), FLOW_BLUR), cv2.GaussianBlur(dst, (0, 0), FLOW_BLUR)
    return dis.calc(np.ascontiguousarray(src), np.ascontiguousarray(dst), None)


def sample(field: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear samples (k, C) of an (H, W, C) float32 field at (k, 2) pixel points (x, y), edges clamped."""
    p = np.asarray(points, np.float32)
    out = cv2.remap(field, p[None, :, 0].copy(), p[None, :, 1].copy(), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(len(p), -1).astype(np.float64)


def vertex_mass(X: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V,) lumped area of each vertex at positions X (V, 2), a third of each incident face's, summing to 1."""
    a = np.abs(signed_areas(X, faces))
    m = np.bincount(faces.ravel(), np.repeat(a / 3.0, 3), minlength=len(X))
    return m / max(m.sum(), 1e-300)


def flow_targets(X: np.ndarray, rendered: np.ndarray, drawing: np.ndarray, visible: np.ndarray,
                 size_px: float) -> tuple[np.ndarray, np.ndarray]:
    """(flow at each vertex (V, 2) px, trust (V,) in [0, 1]) from the rendering to the drawing (H, W) uint8.

    visible: (V,) bool vertices of faces drawn on top (a hidden vertex sees another layer's motion); size_px:
    the character's size, which bounds a trusted flow (MAX_SHIFT)."""
    fwd = dense_flow(rendered, drawing)
    bwd = dense_flow(drawing, rendered)
    f = sample(fwd, X)
    back = sample(bwd, X + f)
    err = np.linalg.norm(f + back, axis=1)
    trust = np.exp(-(err / CONSISTENCY_PX) ** 2) * np.asarray(visible, np.float64)
    trust *= np.linalg.norm(f, axis=1) <= MAX_SHIFT * size_px
    return f, trust


def register(X: np.ndarray, faces: np.ndarray, flow: np.ndarray, trust: np.ndarray, start: np.ndarray | None = None,
             stiffness: float = STIFFNESS, grad_tol: float = GRAD_TOL, max_iter: int = 2000) -> Registration:
    """Displacement D (V, 2) px of the fold-free mesh X (V, 2) px, faces (F, 3), toward start + flow (V, 2)
    where trust (V,) > 0, regularized by the symmetric Dirichlet energy relative to X, solved from the fold-free
    start (V, 2) px (default X: an earlier pass's result to refine); X + D has no folded face."""
    X = np.asarray(X, np.float64)
    start = X if start is None else np.asarray(start, np.float64)
    weights = np.asarray(trust, np.float64) * vertex_mass(X, faces)
    handles = np.flatnonzero(weights > 1e-9)
    if not len(handles):
        return Registration(start - X, np.zeros(len(X)), np.asarray(flow, np.float64), 0)
    d = Deformer(X, faces, handles, mu=stiffness, handle_weights=weights[handles])
    res = d.solve(start[handles] + flow[handles], x0=start, grad_tol=grad_tol, max_iter=max_iter)
    return Registration(res.x - X, np.asarray(trust, np.float64), np.asarray(flow, np.float64), res.iterations)


def ease(u: np.ndarray) -> np.ndarray:
    """Smoothstep 3u^2 - 2u^3 of u clipped to [0, 1]: 0 and 1 at the ends with zero slope, so the lane's
    displacement starts and arrives without a jolt."""
    u = np.clip(np.asarray(u, np.float64), 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def vertex_rotations(X_from: np.ndarray, X_to: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V,) angle (radians) of each vertex's local rotation from mesh X_from to X_to (both (V, 2)): the polar
    rotation of each face's Jacobian, averaged over the vertex's faces (as unit vectors, area-weighted)."""
    E0 = np.stack([X_from[faces[:, 1]] - X_from[faces[:, 0]], X_from[faces[:, 2]] - X_from[faces[:, 0]]], axis=2)
    E1 = np.stack([X_to[faces[:, 1]] - X_to[faces[:, 0]], X_to[faces[:, 2]] - X_to[faces[:, 0]]], axis=2)
    J = E1 @ np.linalg.inv(E0)  # (F, 2, 2)
    c, s = J[:, 0, 0] + J[:, 1, 1], J[:, 1, 0] - J[:, 0, 1]  # the closest rotation's cos and sin, unnormalized
    a = np.abs(signed_areas(X_from, faces))
    norm = np.maximum(np.hypot(c, s), 1e-300)
    n = len(X_from)
    vc = np.bincount(faces.ravel(), np.repeat(a * c / norm, 3), minlength=n)
    vs = np.bincount(faces.ravel(), np.repeat(a * s / norm, 3), minlength=n)
    return np.arctan2(vs, vc)


def fade_in(frames: np.ndarray, displacement: np.ndarray, progress: np.ndarray, end: int, faces: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """frames (T, V, 2) px moved by the displacement (V, 2) px of frame `end`, eased in along progress (T,)
    (0: the lane's own key, 1: the other key) -> (frames (T, V, 2), weight applied per frame (T,)).

    Each frame's displacement is turned by the mesh's local rotation from frame `end` to it, and its weight is
    capped by the injectivity bound, so no frame folds; a frame of weight 0 is returned unchanged."""
    out = np.array(frames, np.float64, copy=True)
    applied = np.zeros(len(out))
    w = ease(progress)
    for i in np.flatnonzero(w > 0):
        turn = vertex_rotations(frames[end], frames[i], faces) if i != end else np.zeros(len(displacement))
        c, s = np.cos(turn)[:, None], np.sin(turn)[:, None]
        Di = w[i] * np.concatenate([c * displacement[:, :1] - s * displacement[:, 1:],
                                    s * displacement[:, :1] + c * displacement[:, 1:]], axis=1)
        step = max_injective_step(out[i], Di, faces)
        out[i] = out[i] + step * Di
        applied[i] = w[i] * step
    return out, applied
