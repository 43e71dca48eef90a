"""Tests of ops.geometry.foreshortening: a limb shortens with its bone's projected length at no cost, keeps its
width, and a bone's share does not reach another limb."""
import numpy as np
import pytest

from ops.geometry.deform import Deformer, count_flipped, deform_sequence
from ops.geometry.energy import SymmetricDirichlet, normalization
from ops.geometry.foreshortening import MIN_RATIO, Foreshortening
from ops.geometry.mesh import face_stretch, triangulate_pslg
from ops.types import Template

L, H = 200.0, 30.0  # px: a limb drawn along x, its bone through the middle


def limb(offset=(0.0, 0.0), parts=((0, 1),)) -> Template:
    """A rectangle drawn along its one bone (joint 0 at x = 10, joint 1 at x = L - 10), handles at sixths of the
    bone, each offset 0 from its bone point; with two parts, a second rectangle beside it on bone (2, 3)."""
    Vs, Fs, hs, ws, fr = [], [], [], [], []
    n = 0
    for k, (a, b) in enumerate(parts):
        dy = k * (H + 20.0)
        u = np.linspace(0.0, 1.0, 7)
        mid = np.stack([10.0 + u * (L - 20.0), np.full(7, H / 2 + dy)], axis=1) + offset
        outer = np.array([[0, dy], [L, dy], [L, dy + H], [0, dy + H]], float) + offset
        res = triangulate_pslg([outer], L * H / 300, points=mid)
        Vs.append(res.V)
        Fs.append(res.F + n)
        hs.append(res.point_vertex + n)
        w = np.zeros((7, 2 * len(parts)))
        w[:, a], w[:, b] = 1.0 - u, u
        ws.append(w)
        fr.append(np.tile([a, b], (7, 1)))
        n += len(res.V)
    J = 2 * len(parts)
    return Template(
        rest=np.concatenate(Vs), faces=np.concatenate(Fs), face_layer=np.zeros(sum(len(f) for f in Fs), np.int64),
        handles=np.concatenate(hs), handle_weights=np.concatenate(ws)[:, :J], handle_offsets=np.zeros((7 * len(parts), 2)),
        handle_frames=np.concatenate(fr), cut_assignment=[], energy=0.0, trials=1, mode="single-layer",
    )


def pose_of(points) -> np.ndarray:
    """(J, 3) pose from (J, 2) joint positions."""
    p = np.asarray(points, np.float64)
    return np.concatenate([p, np.zeros((len(p), 1))], axis=1)


KEY = pose_of([[10.0, H / 2], [L - 10.0, H / 2]])


def test_at_the_key_pose_there_is_no_metric():
    tpl = limb()
    f = Foreshortening(tpl, KEY)
    assert f.metric(KEY) is None
    assert np.allclose(f.ratios(KEY), 1.0)
    moved = pose_of([[50.0, 80.0], [50.0 + (L - 20.0), 80.0]])  # translated: same length
    assert f.metric(moved) is None


def test_a_foreshortened_limb_shortens_at_no_cost_and_keeps_its_width():
    tpl = limb()
    f = Foreshortening(tpl, KEY)
    short = pose_of([[10.0, H / 2], [10.0 + 0.4 * (L - 20.0), H / 2]])
    M = f.metric(short)
    assert M.shape == (len(tpl.faces), 2, 2)
    # every face is wholly on the one bone: its reference is the rest triangle squashed to 0.4 along x
    assert np.allclose(M, np.diag([0.4, 1.0])[None], atol=1e-9)
    targets = tpl.handle_targets(short)
    plain = Deformer(tpl.rest, tpl.faces, tpl.handles).solve(targets)
    d = Deformer(tpl.rest, tpl.faces, tpl.handles)
    d.set_metric(M)
    fore = d.solve(targets)
    assert count_flipped(fore.x, tpl.faces) == 0
    # the squash along the bone is the identity against the metric: E_SD = 4 and the handles met
    assert fore.energy == pytest.approx(4.0, abs=1e-4)
    assert plain.energy > fore.energy + 1.0
    assert np.abs(fore.x[tpl.handles] - targets).max() < 0.05
    ext = np.ptp(fore.x, axis=0)
    assert ext[0] == pytest.approx(0.4 * L, rel=0.01) and ext[1] == pytest.approx(H, rel=0.01)
    stretch = face_stretch(tpl.rest, fore.x, tpl.faces, M)
    assert stretch.max() < 1.01  # no face distorted against its reference


def test_metric_energy_gradient_matches_finite_differences():
    tpl = limb()
    rng = np.random.default_rng(0)
    norm = normalization(tpl.rest, tpl.faces)
    rest_n = norm.to_norm(tpl.rest)
    M = np.eye(2)[None] + 0.3 * rng.standard_normal((len(tpl.faces), 2, 2)) * 0.3
    M = 0.5 * (M + M.transpose(0, 2, 1)) + 0.5 * np.eye(2)[None]  # symmetric positive definite
    e = SymmetricDirichlet(rest_n, tpl.faces, tpl.handles, metric=M)
    X = rest_n + 0.002 * rng.standard_normal(rest_n.shape)
    T = rest_n[tpl.handles] + 0.01
    E, G = e.value_grad(X, T)
    D = rng.standard_normal(X.shape)
    h = 1e-6
    fd = (e.energy(X + h * D, T) - e.energy(X - h * D, T)) / (2 * h)
    assert fd == pytest.approx(float((G * D).sum()), rel=1e-5)


def test_a_bones_share_stays_on_its_limb():
    tpl = limb(parts=((0, 1), (2, 3)))
    key = pose_of([[10.0, H / 2], [L - 10.0, H / 2], [10.0, H / 2 + H + 20.0], [L - 10.0, H / 2 + H + 20.0]])
    f = Foreshortening(tpl, key)
    assert f.face_bone.shape == (len(tpl.faces), 2)
    assert (f.face_bone >= 0).all() and (f.face_bone <= 1).all()
    upper = tpl.rest[tpl.faces].mean(axis=1)[:, 1] < H + 10.0
    bone01 = int(np.nonzero((f.bones == [0, 1]).all(axis=1))[0][0])
    assert np.allclose(f.face_bone[upper, bone01], 1.0) and np.allclose(f.face_bone[~upper, bone01], 0.0)
    # shortening the second limb leaves the first one's reference alone
    moved = key.copy()
    moved[3, 0] = 10.0 + 0.5 * (L - 20.0)
    M = f.metric(moved)
    assert np.allclose(M[upper], np.eye(2)) and np.allclose(M[~upper], np.diag([0.5, 1.0]))


def test_a_bone_seen_end_on_is_clipped():
    tpl = limb()
    f = Foreshortening(tpl, KEY)
    point = pose_of([[10.0, H / 2], [10.0, H / 2]])
    assert f.ratios(point) == pytest.approx([MIN_RATIO])


def test_sequence_through_foreshortening_has_no_folds():
    tpl = limb()
    f = Foreshortening(tpl, KEY)
    poses = np.stack([pose_of([[10.0, H / 2], [10.0 + s * (L - 20.0) * np.cos(a), H / 2 + s * (L - 20.0) * np.sin(a)]])
                      for s, a in ((1.0, 0.0), (0.6, 0.4), (0.3, 0.8), (0.6, 1.2))])
    X, E, _ = deform_sequence(tpl, poses, "forward", metrics=[f.metric(p) for p in poses])
    assert np.allclose(X[0], tpl.rest)
    for x in X:
        assert count_flipped(x, tpl.faces) == 0
    assert E.max() < 4.2  # each frame is a rotation of its reference
