"""Tests of ops.geometry.register and its use by the lanes: a lane registered onto a locally redrawn other key
agrees with it by a margin, no frame folds, the own key's frame is untouched, and the fade never folds."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
import triangle
from hypothesis import given, settings
from hypothesis import strategies as st

from ops.appearance.lane import deform_lane
from ops.appearance.render import Renderer
from ops.evaluation.metrics import psnr
from ops.geometry.deform import count_flipped
from ops.geometry.register import ease, fade_in, register, vertex_rotations
from ops.types import Masks, Template, TexturedTemplate

SIZE, LO, HI = 96, 14.0, 81.0
JOINTS = np.array([[LO + 10, 48.0, 0.0], [HI - 10, 48.0, 0.0]])  # (J, 3): a left and a right joint


def sheet(step: float = 5.0) -> Template:
    """One front sheet over [LO, HI]^2, handles at the two joints (one-hot) and the midpoint between them."""
    up = np.linspace(LO, HI, int((HI - LO) / step) + 1)[:-1]  # one side, its last corner left to the next
    down = up[::-1] + (HI - LO) / len(up)
    lo, hi = np.full_like(up, LO), np.full_like(up, HI)
    ring = np.concatenate([np.stack(p, 1) for p in ((up, lo), (hi, up), (down, hi), (lo, down))])
    pts = np.concatenate([ring, JOINTS[:, :2], [[48.0, 48.0]]])
    i = np.arange(len(ring))
    tri = triangle.triangulate({"vertices": pts, "segments": np.stack([i, (i + 1) % len(ring)], 1)}, "pq30a12Y")
    V, F = tri["vertices"], tri["triangles"].astype(np.int64)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    flip = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    F[flip] = F[flip][:, [0, 2, 1]]
    handles = len(ring) + np.arange(3)
    return Template(rest=V, faces=F, face_layer=np.zeros(len(F), np.int64), handles=handles,
                    handle_weights=np.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]]), handle_offsets=np.zeros((3, 2)),
                    handle_frames=np.full((3, 2), -1), cut_assignment=[], energy=0.0, trials=1, mode="optimized")


def ink() -> np.ndarray:
    """(SIZE, SIZE, 4) straight RGBA: dark strokes (a grid, a circle, a diagonal) on a white sheet."""
    img = np.full((SIZE, SIZE), 255, np.uint8)
    for v in range(22, 80, 12):
        cv2.line(img, (v, 16), (v, 79), 0, 2)
        cv2.line(img, (16, v), (79, v), 0, 1)
    cv2.circle(img, (48, 48), 17, 0, 2)
    cv2.line(img, (18, 20), (78, 76), 0, 2)
    grey = cv2.GaussianBlur(img, (0, 0), 0.7).astype(np.float32) / 255.0
    inside = np.zeros((SIZE, SIZE), np.float32)
    inside[int(LO) + 1:int(HI), int(LO) + 1:int(HI)] = 1.0
    return np.dstack([grey, grey, grey, inside])


def textured(tpl: Template) -> TexturedTemplate:
    n = len(tpl.rest)
    return TexturedTemplate(tpl, np.full((n, 2), 0.5), np.zeros(len(tpl.faces), np.int64), ink(),
                            np.zeros((SIZE, SIZE, 4), np.float32), np.zeros((SIZE, SIZE), bool))


def bump(X: np.ndarray, centre=(60.0, 36.0), radius: float = 12.0, shift=(2.5, 2.0)) -> np.ndarray:
    """(V, 2) a local displacement: `shift` px at `centre`, fading to nothing a few radii away."""
    r2 = ((X - centre) ** 2).sum(1) / radius**2
    return np.exp(-r2)[:, None] * np.asarray(shift)


def masks_of(rgba: np.ndarray) -> Masks:
    """The masks a drawing (H, W, 4) rendered over nothing would have: colour and coverage are what matters."""
    fg = rgba[..., 3] > 0.5
    return Masks(fg, [], [], "manual", rgba[..., 3].astype(np.float32), np.ones((*fg.shape, 3), np.float32),
                 rgba[..., :3].astype(np.float32), np.zeros_like(fg), 0)


def over_white(rgba: np.ndarray) -> np.ndarray:
    return rgba[..., :3] * rgba[..., 3:] + (1.0 - rgba[..., 3:])


def motion(frames: int = 5, dx: float = 8.0) -> tuple[np.ndarray, np.ndarray]:
    """(times (T,), poses (T, J, 3)): the skeleton slides right by dx px."""
    times = np.linspace(0.0, 1.0, frames)
    return times, np.stack([JOINTS + [dx * t, 0.0, 0.0] for t in times])


@pytest.fixture(scope="module")
def scene():
    """Unregistered and registered lanes toward another key: the lane's end frame with a local bump redrawn."""
    tex = textured(sheet())
    times, poses = motion()
    plain = deform_lane(tex, times, poses, False, (SIZE, SIZE))
    X_end = plain.vertices[-1]
    other, _, _ = Renderer(tex).frame(X_end + bump(X_end), poses[-1], (SIZE, SIZE))
    registered = deform_lane(tex, times, poses, False, (SIZE, SIZE), other=masks_of(other))
    return tex, plain, registered, other


def test_registration_raises_agreement_by_a_margin(scene):
    _, plain, registered, other = scene
    before = psnr(over_white(plain.images[-1]), over_white(other))
    after = psnr(over_white(registered.images[-1]), over_white(other))
    assert after > before + 10.0, (before, after)  # 21.7 -> 44.5 dB here
    assert registered.fade[-1] == pytest.approx(1.0)


def test_registration_is_local(scene):
    tex, plain, registered, _ = scene
    X = plain.vertices[-1]
    D = registered.vertices[-1] - X
    far = np.linalg.norm(X - (60.0, 36.0), axis=1) > 36.0  # 3 radii: the bump there is below 1e-3 px
    near = np.linalg.norm(X - (60.0, 36.0), axis=1) < 6.0
    assert np.abs(D[far]).max() < 0.5
    # it found the bump: the displacement near its centre points along the redrawn shift
    assert np.mean(D[near] @ np.array([2.5, 2.0])) / np.linalg.norm([2.5, 2.0]) > 1.5


def test_no_frame_folds_and_the_own_key_is_untouched(scene):
    tex, plain, registered, _ = scene
    assert [count_flipped(x, tex.template.faces) for x in registered.vertices] == [0] * len(registered.times)
    assert registered.vertices[0].tobytes() == plain.vertices[0].tobytes()
    assert registered.images[0].tobytes() == plain.images[0].tobytes()
    assert registered.fade[0] == 0.0 and np.all(np.diff(registered.fade) > 0)
    assert plain.fade is None


def test_a_drawing_that_already_agrees_moves_nothing():
    tex = textured(sheet())
    times, poses = motion()
    plain = deform_lane(tex, times, poses, False, (SIZE, SIZE))
    same = deform_lane(tex, times, poses, False, (SIZE, SIZE), other=masks_of(plain.images[-1]))
    assert np.abs(same.vertices - plain.vertices).max() < 0.1


def test_rotations_of_a_turned_mesh():
    tpl = sheet()
    th = 0.4
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    assert np.allclose(vertex_rotations(tpl.rest, tpl.rest @ R.T + 5.0, tpl.faces), th)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.floats(0.5, 40.0), frames=st.integers(2, 7))
def test_fade_in_never_folds_and_keeps_weight_zero_frames(seed, scale, frames):
    """Whatever the displacement (most of these fold the mesh many times over if applied in full), every faded
    frame is fold-free, takes no more than its eased weight, and the frame at progress 0 is returned as is."""
    tpl = sheet(step=8.0)
    rng = np.random.default_rng(seed)
    turn = np.linspace(0.0, rng.uniform(-0.6, 0.6), frames)
    X = np.stack([tpl.rest @ np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]).T for a in turn])
    D = rng.standard_normal(tpl.rest.shape) * scale
    progress = np.linspace(0.0, 1.0, frames)
    out, applied = fade_in(X, D, progress, frames - 1, tpl.faces)
    assert [count_flipped(x, tpl.faces) for x in out] == [0] * frames
    assert out[0].tobytes() == X[0].tobytes() and applied[0] == 0.0
    assert np.all(applied <= ease(progress) + 1e-12)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.floats(0.5, 30.0))
def test_register_is_injective_for_any_flow(seed, scale):
    """Random, incoherent flows at random trust: the registered mesh never folds, and an untrusted vertex set
    gives no displacement at all."""
    tpl = sheet(step=8.0)
    rng = np.random.default_rng(seed)
    flow = rng.standard_normal(tpl.rest.shape) * scale
    trust = rng.uniform(0, 1, len(tpl.rest)) * (rng.uniform(0, 1, len(tpl.rest)) > 0.3)
    reg = register(tpl.rest, tpl.faces, flow, trust, max_iter=300)
    assert count_flipped(tpl.rest + reg.displacement, tpl.faces) == 0
    assert not register(tpl.rest, tpl.faces, flow, np.zeros(len(tpl.rest))).displacement.any()
