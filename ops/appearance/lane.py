"""One keyframe's lane after the template: texture it, then deform and render it into every pose.

Shared by the pipeline's assets and by the evaluation (which also runs the
single-layer ablation through the same code).
"""
from __future__ import annotations

import numpy as np

from ops.appearance.inpaint import Inpainter
from ops.appearance.render import Renderer, depth_order, rasterize_ids
from ops.appearance.texture import texture_template
from ops.appearance.weights import depth_weights
from ops.geometry.deform import Deformer, deform_sequence
from ops.geometry.register import PASSES, Registration, fade_in, flow_targets, gray_over_white, register
from ops.types import DeformedSequence, Masks, RefinedMasks, Template, TexturedTemplate


def texture_lane(template: Template, own: RefinedMasks, other: RefinedMasks | None, pose: np.ndarray,
                 other_pose: np.ndarray | None, inpainter: Inpainter, mu: float = 200.0, grad_tol: float = 0.01,
                 max_iter: int = 5000, start: np.ndarray | None = None) -> tuple[TexturedTemplate, float]:
    """Depth weights + textures (§5.1) from both keyframes' masks and key poses (J, 3) -> (textured, energy at the
    other). Without another keyframe (None: one drawing) the hidden layers are inpainted and the energy is 0.

    start: (n, 2) pixels, the template already deformed to the other pose (the cut search's solution there,
    Template.target_x, found along the motion): the solve there starts from it instead of from rest, which for a
    limb swung far (a tail curling round) took thousands of iterations and could land in a crumpled minimum."""
    weights = depth_weights(template)
    if other is None:
        return texture_template(template, weights, own, None, pose, None, inpainter), 0.0
    deformer = Deformer(template.rest, template.faces, template.handles, mu=mu)
    targets = template.handle_targets(other_pose)
    x0 = start if start is not None and start.shape == template.rest.shape else None
    if x0 is not None and not np.isfinite(deformer.energy(x0, targets)):
        x0 = None  # folds (not the search's solution for this mesh): from rest
    to_other = deformer.solve(targets, x0=x0, grad_tol=grad_tol, max_iter=max_iter)
    textured = texture_template(template, weights, own, other, pose, to_other.x, inpainter)
    return textured, float(to_other.energy)


def deform_lane(textured: TexturedTemplate, times: np.ndarray, poses: np.ndarray, backward: bool,
                shape: tuple[int, int], mu: float = 200.0, supersample: int = 2, other: Masks | None = None
                ) -> DeformedSequence:
    """Deform into poses (T, J, 3), warm-started from the lane's own keyframe, and render each frame (H, W).

    other: the masks of the key at the segment's other end; given, the lane is registered onto that drawing
    where the skeleton leaves it off, faded in over the segment (ops.geometry.register)."""
    template = textured.template
    X, energies, iters = deform_sequence(template, poses, "backward" if backward else "forward", mu=mu)
    T = len(times)
    images = np.zeros((T, *shape, 4), np.float32)
    inpainted = np.zeros((T, *shape), bool)
    distorted = np.zeros((T, *shape), bool)
    renderer = Renderer(textured)
    fade = None
    if other is not None and T > 1:
        end = 0 if backward else T - 1
        reg = register_toward(renderer, X[end], poses[end], other, supersample)
        t = np.asarray(times, np.float64)
        start = T - 1 - end
        progress = (t - t[start]) / (t[end] - t[start]) if t[end] != t[start] else np.zeros(T)
        X, fade = fade_in(X, reg.displacement, progress, end, template.faces)
    for i in range(T):
        images[i], inpainted[i], distorted[i] = renderer.frame(X[i], poses[i], shape, supersample)
    return DeformedSequence(np.asarray(times, float).copy(), np.asarray(X), images, inpainted,
                            np.asarray(energies, float), np.asarray(iters, np.int64), distorted, fade)


def register_toward(renderer: Renderer, X: np.ndarray, pose: np.ndarray, other: Masks, supersample: int = 2,
                    passes: int = PASSES) -> Registration:
    """The displacement (V, 2) px that moves the lane's mesh X (V, 2), deformed to the other key's pose (J, 3),
    onto that key's drawing: its rendering and the drawing's colour under its coverage, both over white.

    Each pass renders the mesh where the last one left it and follows the flow from there (the flow of a
    stroke a few pixels off is found in full only once the stroke is near)."""
    textured = renderer.textured
    faces = textured.template.faces
    shape = other.coverage.shape
    drawing = gray_over_white(np.concatenate([other.colour, other.coverage[..., None]], axis=-1))
    size_px = float(np.sqrt(max(other.coverage.sum(), 1.0)))
    order = depth_order(textured, pose, renderer.groups)
    Y, iterations, reg = X, 0, None
    for _ in range(passes):
        rgba, _, _ = renderer.frame(Y, pose, shape, supersample)
        ids = rasterize_ids(Y, faces, order, shape, 1)
        visible = np.zeros(len(X), bool)
        visible[faces[np.unique(ids[ids >= 0])].ravel()] = True
        flow, trust = flow_targets(Y, gray_over_white(rgba), drawing, visible, size_px)
        reg = register(X, faces, flow, trust, start=Y)
        Y, iterations = X + reg.displacement, iterations + reg.iterations
    reg.iterations = iterations
    return reg
