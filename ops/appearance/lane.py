"""One keyframe's lane after the template: texture it, then deform and render it into every pose.

Shared by the pipeline's assets and by the evaluation (which also runs the
single-layer ablation through the same code).
"""
from __future__ import annotations

import numpy as np

from ops.appearance.inpaint import Inpainter
from ops.appearance.render import Renderer
from ops.appearance.texture import texture_template
from ops.appearance.weights import depth_weights
from ops.geometry.deform import Deformer, deform_sequence
from ops.types import DeformedSequence, RefinedMasks, Template, TexturedTemplate


def texture_lane(template: Template, own: RefinedMasks, other: RefinedMasks | None, pose: np.ndarray,
                 other_pose: np.ndarray | None, inpainter: Inpainter, mu: float = 200.0, grad_tol: float = 0.01,
                 max_iter: int = 5000) -> tuple[TexturedTemplate, float]:
    """Depth weights + textures (§5.1) from both keyframes' masks and key poses (J, 3) -> (textured, energy at the
    other). Without another keyframe (None: one drawing) the hidden layers are inpainted and the energy is 0."""
    weights = depth_weights(template)
    if other is None:
        return texture_template(template, weights, own, None, pose, None, inpainter), 0.0
    deformer = Deformer(template.rest, template.faces, template.handles, mu=mu)
    to_other = deformer.solve(template.handle_targets(other_pose), grad_tol=grad_tol, max_iter=max_iter)
    textured = texture_template(template, weights, own, other, pose, to_other.x, inpainter)
    return textured, float(to_other.energy)


def deform_lane(textured: TexturedTemplate, times: np.ndarray, poses: np.ndarray, backward: bool,
                shape: tuple[int, int], mu: float = 200.0, supersample: int = 2) -> DeformedSequence:
    """Deform into poses (T, J, 3), warm-started from the lane's own keyframe, and render each frame (H, W)."""
    template = textured.template
    deformer = Deformer(template.rest, template.faces, template.handles, mu=mu)
    X, energies, iters = deform_sequence(template, poses, "backward" if backward else "forward", deformer)
    T = len(times)
    images = np.zeros((T, *shape, 4), np.float32)
    inpainted = np.zeros((T, *shape), bool)
    distorted = np.zeros((T, *shape), bool)
    renderer = Renderer(textured)
    for i in range(T):
        images[i], inpainted[i], distorted[i] = renderer.frame(X[i], poses[i], shape, supersample)
    return DeformedSequence(np.asarray(times, float).copy(), np.asarray(X), images, inpainted,
                            np.asarray(energies, float), np.asarray(iters, np.int64), distorted)
