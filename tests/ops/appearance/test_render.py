"""Tests of the CPU renderer: id raster, rest reproduction, translation, depth order, inpainted mask."""
from __future__ import annotations

import time

import numpy as np
import pytest
import triangle

from ops.appearance.render import (
    DISTORTION_LIMIT,
    Renderer,
    Window,
    affine_maps,
    depth_order,
    rasterize_ids,
    render,
)
from ops.geometry.mesh import face_stretch
from ops.types import Template, TexturedTemplate


def _ring(x0: float, y0: float, x1: float, y1: float, step: float) -> np.ndarray:
    """(k, 2) points every ~step px along an axis-aligned rectangle, counter-clockwise, corners included."""
    nx, ny = max(1, round((x1 - x0) / step)), max(1, round((y1 - y0) / step))
    bottom = np.stack([np.linspace(x0, x1, nx + 1)[:-1], np.full(nx, y0)], 1)
    right = np.stack([np.full(ny, x1), np.linspace(y0, y1, ny + 1)[:-1]], 1)
    top = np.stack([np.linspace(x1, x0, nx + 1)[:-1], np.full(nx, y1)], 1)
    left = np.stack([np.full(ny, x0), np.linspace(y1, y0, ny + 1)[:-1]], 1)
    return np.concatenate([bottom, right, top, left])


def _loop(start: int, k: int) -> np.ndarray:
    """(k, 2) closed segment list over vertices start .. start + k - 1."""
    i = np.arange(k)
    return np.stack([start + i, start + (i + 1) % k], 1)


def _positive(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Reorder faces so that their signed area (image coordinates) is positive."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    F = F.copy()
    F[area < 0] = F[area < 0][:, [0, 2, 1]]
    return F


def make_template(size: int = 64, lo: float = 7.5, pocket=(24.0, 24.0, 40.0, 40.0), step: float = 4.0,
                  max_area: float = 8.0, sewn: bool = True) -> Template:
    """Square front sheet [lo, size-1-lo]^2 with a rectangular pocket sewn along its left side.

    Joints: 0 at the left, 1 at the right, 2 at the top of the sheet; handles at the three joints (one-hot)
    and at the midpoint of bone (0, 1) (0.5 / 0.5).
    """
    hi = size - 1 - lo
    outer = _ring(lo, lo, hi, hi, step)
    inner = _ring(*pocket, step)
    mid = (lo + hi) / 2
    joints = np.array([[lo + (hi - lo) / 6, mid], [hi - (hi - lo) / 6, mid], [mid, lo + (hi - lo) / 6],
                       [mid, (mid + hi) / 2]])
    pts = np.concatenate([outer, inner, joints])
    segs = np.concatenate([_loop(0, len(outer)), _loop(len(outer), len(inner))])
    front = triangle.triangulate({"vertices": pts, "segments": segs}, f"pq30a{max_area}Y")
    Vf, Ff = front["vertices"], front["triangles"].astype(np.int64)
    back = triangle.triangulate({"vertices": inner, "segments": _loop(0, len(inner))}, f"pq30a{max_area}Y")
    Vb, Fb = back["vertices"], back["triangles"].astype(np.int64)
    assert np.allclose(Vf[len(outer):len(outer) + len(inner)], inner) and np.allclose(Vb[:len(inner)], inner)
    # pocket vertices: the sewn (left) side reuses the front sheet's, every other one is a copy
    index = np.empty(len(Vb), dtype=np.int64)
    sewn_mask = np.zeros(len(Vb), dtype=bool)
    if sewn:
        sewn_mask[:len(inner)] = np.isclose(inner[:, 0], pocket[0])
    index[sewn_mask] = len(outer) + np.nonzero(sewn_mask)[0]
    index[~sewn_mask] = len(Vf) + np.arange((~sewn_mask).sum())
    V = np.concatenate([Vf, Vb[~sewn_mask]])
    F = _positive(V, np.concatenate([Ff, index[Fb]]))
    layer = np.concatenate([np.zeros(len(Ff), np.int64), np.ones(len(Fb), np.int64)])
    jv = len(outer) + len(inner) + np.arange(4)
    hw = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0]], dtype=np.float64)
    return Template(rest=V, faces=F, face_layer=layer, handles=jv, handle_weights=hw,
                    handle_offsets=np.zeros((len(jv), 2)), handle_frames=np.full((len(jv), 2), -1),
                    cut_assignment=[np.zeros(4, np.int8)], energy=0.0, trials=1, mode="optimized")


def pattern(size: int) -> np.ndarray:
    """(size, size, 3) float32 smooth colourful test drawing."""
    y, x = np.mgrid[0:size, 0:size].astype(np.float32)
    return np.stack([0.5 + 0.4 * np.sin(x / 5.0), 0.5 + 0.4 * np.cos(y / 6.0),
                     0.5 + 0.3 * np.sin((x + y) / 9.0)], axis=2).astype(np.float32)


def square_foreground(size: int, lo: float) -> np.ndarray:
    """(size, size) bool pixels whose centres lie in [lo, size-1-lo]^2."""
    c = np.arange(size)
    inside = (c >= lo) & (c <= size - 1 - lo)
    return inside[:, None] & inside[None, :]


def textured(tpl: Template, size: int, back_rgb=(1.0, 0.0, 0.0), source: int = 1,
             inpainted: bool = False) -> TexturedTemplate:
    """Hand-made textures: front = pattern, back = constant colour; weights one-hot per layer (J = 2)."""
    n = tpl.rest.shape[0]
    pocket_only = np.zeros(n, dtype=bool)
    pocket_only[np.unique(tpl.faces[tpl.face_layer > 0])] = True
    pocket_only[np.unique(tpl.faces[tpl.face_layer == 0])] = False  # sewn vertices belong to the front sheet
    W = np.zeros((n, 2))
    W[~pocket_only, 0] = 1.0
    W[pocket_only, 1] = 1.0
    tex = np.concatenate([pattern(size), square_foreground(size, 7.5)[..., None]], 2).astype(np.float32)
    back = np.zeros((size, size, 4), np.float32)
    back[..., :3] = back_rgb
    back[..., 3] = 1.0
    src = np.where(tpl.face_layer > 0, source, 0).astype(np.int64)
    return TexturedTemplate(tpl, W, src, tex, back, np.full((size, size), inpainted))


def point_in_triangle_distance(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """P (p, 2), T (m, 3, 2) -> (p, m) signed distance to each triangle's edges (positive inside)."""
    d = np.full((P.shape[0], T.shape[0]), np.inf)
    for k in range(3):
        a, b = T[:, k], T[:, (k + 1) % 3]
        e = b - a
        L = np.linalg.norm(e, axis=1)
        # faces are positive in image coordinates, so the interior is to the left of (a -> b) in y-up terms
        cross = e[None, :, 0] * (P[:, None, 1] - a[None, :, 1]) - e[None, :, 1] * (P[:, None, 0] - a[None, :, 0])
        d = np.minimum(d, cross / L[None])
    return d


@pytest.mark.parametrize("scale", [1, 2, 3])
def test_rasterize_convention_half_pixel_edges(scale):
    # edges on pixel boundaries: x = 9.5 is sample 10s - 0.5 of the s-times grid, so samples 0 .. 10s are
    # covered (cv2 includes samples within half a sample of an edge) and nothing beyond
    X = np.array([[-0.5, -0.5], [9.5, -0.5], [9.5, 4.5], [-0.5, 4.5]])
    F = np.array([[0, 1, 2], [0, 2, 3]])
    ids = rasterize_ids(X, _positive(X, F), np.array([0, 1]), (8, 12), scale)
    covered = ids >= 0
    assert covered[:5 * scale + 1, :10 * scale + 1].all()
    assert not covered[5 * scale + 1:].any() and not covered[:, 10 * scale + 1:].any()
    # a quarter sample further in, the edge no longer reaches the next sample
    ids = rasterize_ids(X - 0.26 / scale, _positive(X, F), np.array([0, 1]), (8, 12), scale)
    assert (ids >= 0).sum() == (5 * scale) * (10 * scale)


@pytest.mark.parametrize("scale", [1, 2])
def test_rasterize_ids_brute_force(scale):
    tpl = make_template(size=32, lo=3.3, pocket=(12.2, 12.2, 20.7, 20.7), step=3.1, max_area=6.0)
    front = np.nonzero(tpl.face_layer == 0)[0]
    rng = np.random.default_rng(0)
    X = tpl.rest + rng.uniform(-0.3, 0.3, tpl.rest.shape)  # off-grid vertices, still a planar mesh
    ids = rasterize_ids(X, tpl.faces, front, (32, 32), scale)
    ys, xs = np.mgrid[0:32 * scale, 0:32 * scale]
    P = np.stack([xs.ravel(), ys.ravel()], 1).astype(np.float64)
    T = (X[tpl.faces[front]] + 0.5) * scale - 0.5
    d = point_in_triangle_distance(P, T)  # (p, |front|)
    got = ids.ravel()
    inside_any = d.max(axis=1) > 1e-2
    assert (got[inside_any] >= 0).all(), "hole inside the mesh"
    # a sample well inside one triangle gets exactly that triangle
    deep = d.max(axis=1) > 1.0
    assert np.array_equal(got[deep], front[d[deep].argmax(axis=1)])
    # any assigned face contains the sample up to the rasterizer's one-pixel edge inclusion
    hit = got >= 0
    col = np.searchsorted(front, got[hit])
    assert (d[np.nonzero(hit)[0], col] > -1.0).all()
    assert (got[d.max(axis=1) < -1.0] == -1).all()


def test_affine_maps_reproduce_vertices():
    rng = np.random.default_rng(1)
    src, dst = rng.normal(size=(20, 3, 2)), rng.normal(size=(20, 3, 2))
    A = affine_maps(src, dst)
    out = np.einsum("mij,mkj->mki", A[:, :, :2], src) + A[:, None, :, 2]
    assert np.allclose(out, dst)


def test_render_rest_reproduces_drawing():
    size = 64
    tpl = make_template(size)
    tex = textured(tpl, size)
    rgba, inpainted = render(tex, tpl.rest, np.zeros((2, 3)), supersample=2)
    fg = square_foreground(size, 7.5)
    from scipy.ndimage import binary_dilation, binary_erosion
    inner = binary_erosion(fg, iterations=2)
    # read at pixel centres: the template at rest reproduces its texture exactly, not blurred by the supersamples
    assert np.abs(rgba[inner][:, :3] - tex.texture[inner][:, :3]).max() < 1e-5
    assert np.allclose(rgba[inner, 3], 1.0, atol=1e-6)
    assert np.all(rgba[~binary_dilation(fg, np.ones((3, 3), bool)), 3] == 0.0)
    assert np.abs(rgba[..., 3] - fg).mean() < 0.05
    assert not inpainted.any()


def test_render_translation_shifts_image():
    size = 64
    tpl = make_template(size)
    tex = textured(tpl, size)
    base, _ = render(tex, tpl.rest, np.zeros((2, 3)))
    moved, _ = render(tex, tpl.rest + np.array([7.0, 3.0]), np.zeros((2, 3)))
    assert np.abs(moved[3:, 7:] - base[:-3, :-7]).max() < 1e-4
    assert np.all(moved[:3] == 0) and np.all(moved[:, :7] == 0)


def test_depth_order_ties_put_pockets_behind():
    tpl = make_template()
    order = depth_order(textured(tpl, 64), np.zeros((2, 3)))
    layer = tpl.face_layer[order]
    assert layer[:(layer > 0).sum()].min() > 0  # every pocket face before every front face


@pytest.mark.parametrize("pocket_z, in_front", [(-1.0, True), (1.0, False)])
def test_pocket_occludes_front_by_depth(pocket_z, in_front):
    size = 64
    tpl = make_template(size)
    pose = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, pocket_z]])
    rgba, inpainted = render(textured(tpl, size, source=2, inpainted=True), tpl.rest, pose)
    inside = rgba[28:37, 28:37, :3]  # well inside the pocket [24, 40]^2
    red = np.abs(inside - np.array([1.0, 0.0, 0.0])).max(axis=2) < 1e-3
    assert red.all() if in_front else not red.any()
    assert inpainted.any() == in_front
    if in_front:  # the mask covers the visible pocket interior and nothing outside it
        assert inpainted[26:39, 26:39].all()
        assert not inpainted[:20].any() and not inpainted[45:].any()


def test_inpainted_mask_empty_for_other_keyframe_texture():
    size = 64
    tpl = make_template(size)
    pose = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    _, inpainted = render(textured(tpl, size, source=1, inpainted=False), tpl.rest, pose)
    assert not inpainted.any()


def test_render_time_384():
    size = 384
    tpl = make_template(size, lo=31.5, pocket=(140.0, 140.0, 240.0, 240.0), step=12.0, max_area=120.0)
    assert 1000 < tpl.faces.shape[0] < 2500
    tex = textured(tpl, size)
    render(tex, tpl.rest, np.zeros((2, 3)))
    t0 = time.perf_counter()
    for _ in range(3):
        render(tex, tpl.rest + 1.3, np.zeros((2, 3)), supersample=2)
    per_frame = (time.perf_counter() - t0) / 3
    print(f"render 384x384, {tpl.faces.shape[0]} faces, s=2: {per_frame * 1e3:.1f} ms/frame")
    assert per_frame < 0.5  # target 0.2 s; slack for the shared test machine


def test_distorted_pixels_are_those_of_faces_scaled_past_the_limit():
    size = 64
    tpl = make_template(size)
    tex = textured(tpl, size)
    renderer = Renderer(tex)
    _, _, at_rest = renderer.frame(tpl.rest, np.zeros((2, 3)))
    assert not at_rest.any()
    # the right half of the sheet pulled 3x wider: its faces are torn, the left half's untouched ones are not
    X = tpl.rest.copy()
    right = X[:, 0] > 32
    X[right, 0] = 32 + 3.0 * (X[right, 0] - 32)
    rgba, _, distorted = Renderer(tex).frame(X, np.zeros((2, 3)), (64, 160))
    stretched = np.append(face_stretch(tpl.rest, X, tpl.faces) > DISTORTION_LIMIT, False)
    assert stretched[:-1].any() and not stretched[:-1].all()
    shown = rgba[..., 3] > 0.5
    assert distorted[:, 100:][shown[:, 100:]].all()  # deep in the pulled half
    assert not distorted[:, :25].any()  # the untouched left part
    assert not (distorted & ~shown).any()


def _slit_sheet() -> TexturedTemplate:
    """Front sheet of two rectangles slit apart along x = 28 (their vertices there doubled, as cut_along leaves
    them): A [8, 28] x [8, 40] follows joint 0 and is translucent red (a pale limb's soft edge), B [28, 56] x
    [8, 40] follows joint 1 and is opaque blue."""
    parts, faces, n = [], [], 0
    for x0, x1 in ((8.0, 28.0), (28.0, 56.0)):
        ring = _ring(x0, 8.0, x1, 40.0, 4.0)
        t = triangle.triangulate({"vertices": ring, "segments": _loop(0, len(ring))}, "pq30a8Y")
        parts.append(t["vertices"])
        faces.append(t["triangles"].astype(np.int64) + n)
        n += len(t["vertices"])
    V = np.concatenate(parts)
    F = _positive(V, np.concatenate(faces))
    in_a = np.zeros(len(V), bool)
    in_a[:len(parts[0])] = True
    W = np.stack([in_a, ~in_a], axis=1).astype(np.float64)
    tpl = Template(rest=V, faces=F, face_layer=np.zeros(len(F), np.int64), handles=np.array([0, len(parts[0])]),
                   handle_weights=np.eye(2), handle_offsets=np.zeros((2, 2)), handle_frames=np.full((2, 2), -1),
                   cut_assignment=[], energy=0.0, trials=1, mode="optimized")
    tex = np.zeros((48, 64, 4), np.float32)
    tex[8:41, 8:28] = (1.0, 0.0, 0.0, 0.5)
    tex[8:41, 28:57] = (0.0, 0.0, 1.0, 1.0)
    return TexturedTemplate(tpl, W, np.zeros(len(F), np.int64), tex, np.zeros_like(tex), np.zeros((48, 64), bool)), in_a


def test_a_slit_limb_over_the_body_shows_the_body_through_its_soft_edge():
    tt, in_a = _slit_sheet()
    pose = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 0.0]])  # joint 0 (A) in front
    renderer = Renderer(tt)
    # at rest the slit's two sides meet edge to edge: nothing is composited twice, the texture comes back
    rest, _, _ = renderer.frame(tt.template.rest, pose, supersample=2)
    inner = (slice(10, 39), slice(10, 55))  # the seam at x = 28 included, the outline's half-covered pixels not
    assert np.abs(rest[inner] - tt.texture[inner]).max() < 1e-5
    # A moved 10 px right lies over B: its half-transparent red over B's blue, not over the paper
    X = tt.template.rest + np.where(in_a[:, None], [10.0, 0.0], 0.0)
    rgba, _, _ = renderer.frame(X, pose, supersample=2)
    assert np.allclose(rgba[20:30, 31:36], (0.5, 0.0, 0.5, 1.0), atol=1e-4)
    assert np.allclose(rgba[20:30, 20:26], (1.0, 0.0, 0.0, 0.5), atol=1e-4)  # over nothing it stays translucent
    assert np.allclose(rgba[20:30, 42:50], (0.0, 0.0, 1.0, 1.0), atol=1e-4)


@pytest.mark.parametrize("scale", [1, 2, 3])
def test_a_window_rasterizes_exactly_as_the_whole_frame(scale):
    """rasterize_ids of a window starting at a pixel origin equals that window of the whole frame's ids."""
    tpl = make_template(size=32, lo=3.3, pocket=(12.2, 12.2, 20.7, 20.7), step=3.1, max_area=6.0)
    rng = np.random.default_rng(1)
    X = tpl.rest * 0.7 + 5.0 + rng.uniform(-0.3, 0.3, tpl.rest.shape)
    order = np.arange(len(tpl.faces))
    whole = rasterize_ids(X, tpl.faces, order, (40, 44), scale)
    window = Window.around(X, (40, 44))
    assert window.shape[0] < 40 and window.shape[1] < 44  # a real window, not the frame
    part = rasterize_ids(X, tpl.faces, order, window.shape, scale, window.origin)
    y0, x0 = window.origin
    np.testing.assert_array_equal(part, whole[y0 * scale:window.y1 * scale, x0 * scale:window.x1 * scale])
    outside = whole.copy()
    outside[y0 * scale:window.y1 * scale, x0 * scale:window.x1 * scale] = -1
    assert (outside == -1).all()  # nothing of the mesh falls outside its window


def test_a_mesh_partly_off_the_frame_and_one_wholly_off_it_render():
    """The window is clipped to the frame: a mesh half outside renders its inside half; one wholly outside
    renders nothing (transparent, no inpainted or distorted pixel)."""
    tpl = make_template()
    r = Renderer(textured(tpl, 64))
    pose = np.zeros((2, 3))
    half = r.frame(tpl.rest + [-40.0, 0.0], pose, (64, 64))[0]
    assert half[..., 3].max() > 0.5 and half[:, 40:, 3].max() == 0.0
    gone = r.frame(tpl.rest + [500.0, 0.0], pose, (64, 64))
    assert not gone[0].any() and not gone[1].any() and not gone[2].any()
