"""Live re-pose: the live view equals the pipeline's renderer over white, and a drag deforms the template."""
from __future__ import annotations

import numpy as np

from editor.repose import OverWhite, Reposer
from ops.appearance.render import render
from ops.appearance.weights import depth_weights
from ops.geometry.mesh import triangulate
from ops.shotio.image_io import composite_over_white
from ops.types import Template, TexturedTemplate

H, W = 40, 80
JOINTS = np.array([[12.0, 20.0, 0.0], [40.0, 20.0, 0.0], [67.0, 20.0, 0.0]])  # a three-joint arm along the bar


def bar() -> TexturedTemplate:
    """A 60 x 20 px bar, handles at the three joints; the right half is a pocket layer with its own texture."""
    outer = np.array([[10.0, 10.0], [70.0, 10.0], [70.0, 30.0], [10.0, 30.0]])
    V, F = triangulate([outer], max_area=8.0)
    handles = np.array([int(np.argmin(np.linalg.norm(V - j[:2], axis=1))) for j in JOINTS])
    layer = (V[F].mean(axis=1)[:, 0] > 45).astype(np.int64)
    tpl = Template(rest=V, faces=F, face_layer=layer, handles=handles, handle_weights=np.eye(3),
                   handle_offsets=np.zeros((3, 2)), handle_frames=np.full((3, 2), -1),
                   cut_assignment=[], energy=0.0, trials=1, mode="optimized")
    front = np.zeros((H, W, 4), np.float32)
    front[..., 0] = ((np.arange(W) // 4) % 2)[None, :] * 0.9  # red stripes
    front[10:31, 10:71, 3] = 1.0
    front[10:31, 10:71][::3, :, 3] = 0.5  # some partial coverage
    back = np.zeros((H, W, 4), np.float32)
    back[..., 2] = 0.7
    back[10:31, 10:71, 3] = 1.0
    # the right half is hidden at the keyframe: it shows the back texture
    return TexturedTemplate(tpl, depth_weights(tpl), layer.copy(), front, back, np.zeros((H, W), bool))


def test_live_view_is_the_renderer_over_white():
    textured = bar()
    X = textured.template.rest.copy()
    X[:, 1] += 0.15 * (X[:, 0] - 10)  # a shear: every face mapped, both layers visible
    rgba, _ = render(textured, X, JOINTS, (H, W), supersample=1)
    expected = np.round(np.clip(composite_over_white(rgba), 0, 1) * 255)
    live = OverWhite(textured)(X, JOINTS, (H, W))
    assert live.shape == (H, W, 4) and live.dtype == np.uint8 and (live[..., 3] == 255).all()
    assert np.abs(live[..., :3].astype(float) - expected).max() <= 1
    assert live[0, 0, :3].tolist() == [255, 255, 255]  # paper
    assert live[26, 60, 2] > 150 and live[26, 60, 0] < 50  # the pocket layer shows its own (blue) texture


def test_drag_deforms_and_warm_starts():
    textured = bar()
    reposer = Reposer(textured, None, mu=200.0)
    pose = JOINTS.copy()
    still = reposer.update(pose, 0.5).image
    pose[2, 1] -= 8.0  # drag the end of the arm up
    first = reposer.update(pose, 0.5)
    assert first.iterations > 0
    moved = first.image
    assert (moved != still).any()
    # the bar's right end follows the joint: ink appears above the bar there, paper below it
    assert (moved[8, 62:69, :3] < 250).any() and (still[8, 62:69, :3] == 255).all()
    pose[2, 1] -= 0.5
    second = reposer.update(pose, 0.5)
    assert second.iterations < first.iterations  # warm-started from the previous update
    half = reposer.update(pose, 0.5, scale=0.5).image
    assert half.shape == (H // 2, W // 2, 4)
