"""Tests of ops.geometry.mesh and ops.geometry.polygon: CDT with constraint loops, repairs, orientation,
boundary loops, polygon area and point-in-polygon."""
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from ops.geometry.mesh import (
    POINT_CLEARANCE_PX,
    _planar,
    boundary_loops,
    cut_along,
    face_stretch,
    signed_areas,
    triangulate,
    triangulate_pslg,
    vertex_components,
)
from ops.geometry.polygon import points_in_polygon, polygon_area, project_to_polyline


def square(x0, y0, s, n_side=1):
    """Closed square polyline (4 * n_side, 2), counter-clockwise in raw coordinates."""
    t = np.linspace(0, 1, n_side, endpoint=False)[:, None]
    c = np.array([[x0, y0], [x0 + s, y0], [x0 + s, y0 + s], [x0, y0 + s]], float)
    return np.concatenate([c[i] + t * (c[(i + 1) % 4] - c[i]) for i in range(4)])


def test_area_and_orientation_and_max_area():
    outer = square(0, 0, 100, 3)
    V, F = triangulate([outer], max_area=20.0)
    a = signed_areas(V, F)
    assert (a > 0).all()
    assert a.max() <= 20.0 + 1e-9
    assert np.isclose(a.sum(), 100 * 100)
    # Clockwise input gives the same positive orientation.
    V2, F2 = triangulate([outer[::-1]], max_area=20.0)
    assert (signed_areas(V2, F2) > 0).all()


def test_internal_loop_is_constrained_and_hole_is_removed():
    outer, inner = square(0, 0, 100, 2), square(30.3, 30.7, 40, 2)
    res = triangulate_pslg([outer, inner], max_area=30.0)
    lv = res.loop_vertex[1]
    # Every inner-loop input vertex is a mesh vertex at the same position.
    assert np.allclose(res.V[lv], inner)
    # The inner polygon is a union of faces: areas inside/outside add up exactly.
    inside = points_in_polygon(res.V[res.F].mean(1), inner)
    a = signed_areas(res.V, res.F)
    assert np.isclose(a[inside].sum(), 40 * 40)
    assert np.isclose(a.sum(), 100 * 100)
    V, F = triangulate([outer, inner], max_area=30.0, holes=np.array([[50.0, 50.0]]))
    assert np.isclose(signed_areas(V, F).sum(), 100 * 100 - 40 * 40)
    loops = boundary_loops(F)
    assert len(loops) == 2
    assert np.isclose(abs(polygon_area(V[loops[0]])), 100 * 100)
    assert np.isclose(abs(polygon_area(V[loops[1]])), 40 * 40)


def test_duplicates_repaired_and_reported():
    outer = square(0, 0, 50, 2)
    dup = np.insert(outer, 3, outer[2], axis=0)  # zero-length segment
    inner = square(10, 10, 20)  # passed twice: every vertex and segment repeated
    warns: list[str] = []
    V, F = triangulate([dup, inner, inner.copy()], max_area=10.0, warnings=warns)
    assert (signed_areas(V, F) > 0).all()
    assert any("duplicate" in w for w in warns)
    assert any("zero-length" in w for w in warns)
    assert any("repeated segment" in w for w in warns)


def test_extra_points_become_vertices_and_outside_points_dropped():
    outer = square(0, 0, 50)
    pts = np.array([[12.5, 17.25], [25.0, 25.0], [80.0, 10.0]])
    res = triangulate_pslg([outer], 10.0, points=pts)
    assert np.allclose(res.V[res.point_vertex[:2]], pts[:2])
    assert res.point_vertex[2] == -1
    assert any("outside" in w for w in res.warnings)


@pytest.mark.parametrize("offset", [0.0, 2e-4, -3e-3, 0.049])
def test_a_point_a_hair_off_a_constraint_loop_leaves_no_flat_face(offset):
    """A handle 2e-4 px from an occlusion region's loop (one_girl_wave) made Triangle emit a flat sliver; the point
    is moved off the segment to POINT_CLEARANCE_PX, so every face keeps a real area and the point a vertex."""
    outer, inner = square(0, 0, 60), square(20, 20, 20, n_side=3)
    p = np.array([[26.3, 20.0 + offset], [31.1, 40.0 - offset], [40.0, 40.0]])  # two near an edge, one on a corner
    res = triangulate_pslg([outer, inner], 4.0, points=p)
    assert signed_areas(res.V, res.F).min() > 1e-3
    moved = np.linalg.norm(res.V[res.point_vertex] - p, axis=1)
    assert (res.point_vertex >= 0).all() and moved.max() <= POINT_CLEARANCE_PX + 1e-9
    assert moved[2] == 0.0  # a point on a loop vertex merges with it


# two overlapping regions of the generator's true occlusion masks (a held-out folded arm): a vertex of the first
# lies exactly on an edge of the second where that edge crosses the first; Triangle alone dies on it (SIGSEGV)
CROSSED_REGION = [[152.9999378845944, 115.0000396899187], [153.99966430664062, 122.99942016601562],
                  [143.9962921142578, 128.01739501953125], [134.8, 124.2], [123.99974822998047, 119.0],
                  [128.00001525878906, 106.00001525878906], [147.9989013671875, 111.00210571289062]]
CROSSING_REGION = [[130.0, 117.0], [136.0, 126.0], [120.0, 140.0]]


def test_regions_crossing_at_a_vertex_triangulate_instead_of_crashing():
    """In a process of its own, since the failure is a segmentation fault: the two regions inside a square mesh,
    every input point a vertex, every face with a real area, the square's area covered."""
    code = textwrap.dedent(f"""
        import numpy as np
        from ops.geometry.mesh import signed_areas, triangulate_pslg
        outer = np.array([[100.0, 90.0], [180.0, 90.0], [180.0, 150.0], [100.0, 150.0]])
        res = triangulate_pslg([outer, np.array({CROSSED_REGION}), np.array({CROSSING_REGION})], 8.729)
        areas = signed_areas(res.V, res.F)
        assert areas.min() > 1e-4, areas.min()
        assert abs(areas.sum() - 80 * 60) < 1e-6, areas.sum()
        assert all((ix >= 0).all() for ix in res.loop_vertex)
        assert any("cross" in w for w in res.warnings), res.warnings
        print("ok")
    """)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and run.stdout.strip() == "ok", (run.returncode, run.stderr[-2000:])


def test_generic_crossings_are_left_to_triangle_and_degenerate_ones_planarized():
    """Loops that cross at generic points reach Triangle as given (it inserts the crossings; the meshes of every
    evaluated shot stay as they were); a vertex on another loop's edge, or two vertices 1e-6 px apart, is
    degenerate and made planar first."""
    outer = square(0, 0, 60)
    a, b = square(10, 10, 20, n_side=2), square(21.3, 17.1, 20, n_side=3)
    plain = triangulate_pslg([outer, a, b], 4.0)
    assert not any("planar" in w for w in plain.warnings)
    on_edge = np.array([[15.0, 10.0], [35.0, 5.0], [35.0, 15.0]])  # its first vertex on a's bottom edge
    near = b.copy()
    near[0] = a[1] + [1e-6, 0.0]
    for loops in ([outer, a, on_edge], [outer, a, near]):
        res = triangulate_pslg(loops, 4.0)
        assert any("planar" in w for w in res.warnings)
        assert signed_areas(res.V, res.F).min() > 1e-4


def _proper_crossings(U, S):
    A, B = U[S[:, 0]], U[S[:, 1]]
    D = B - A
    n = 0
    for i in range(len(S)):
        for j in range(i + 1, len(S)):
            if set(S[i]) & set(S[j]):
                continue
            den = D[i, 0] * D[j, 1] - D[i, 1] * D[j, 0]
            if den == 0:
                continue
            e = A[j] - A[i]
            ti, tj = (e[0] * D[j, 1] - e[1] * D[j, 0]) / den, (e[0] * D[i, 1] - e[1] * D[i, 0]) / den
            n += 0 < ti < 1 and 0 < tj < 1
    return n


@pytest.mark.parametrize("seed", range(6))
def test_planar_graph_has_no_crossings_or_touches_and_keeps_every_segments_points(seed):
    """Random crossing polygons (brute force over all pairs): afterwards no two segments cross, no vertex lies
    within the tolerance of a segment's interior nor of another vertex, the input vertices stay where they were
    (merged within the tolerance), every piece lies on an input segment, and the pieces' total length is the
    input's."""
    rng = np.random.default_rng(seed)
    loops = [rng.uniform(0, 40, (int(rng.integers(3, 8)), 2)) for _ in range(3)]
    loops.append(np.array(CROSSED_REGION) - 110.0)
    U = np.concatenate(loops)
    offs = np.cumsum([0] + [len(L) for L in loops])
    S = np.concatenate([np.stack([np.arange(a, b), np.roll(np.arange(a, b), -1)], 1) for a, b in zip(offs, offs[1:])])
    M = np.ones(len(S), np.int32)
    M[:2] = 2
    assert _proper_crossings(U, S) > 0
    warnings = []
    U2, S2, M2, index = _planar(U, S, M, warnings)
    assert np.linalg.norm(U2[index] - U, axis=1).max() < 2 * POINT_CLEARANCE_PX and warnings  # merged, if at all
    assert (np.linalg.norm(U2[:, None] - U2[None], axis=2) + np.eye(len(U2)) >= POINT_CLEARANCE_PX).all()
    assert _proper_crossings(U2, S2) == 0
    A, B = U2[S2[:, 0]], U2[S2[:, 1]]
    for k in range(len(U2)):
        D = B - A
        t = ((U2[k] - A) * D).sum(1) / (D ** 2).sum(1)
        gap = np.linalg.norm(A + t[:, None] * D - U2[k], axis=1)
        inside = (t > 0) & (t < 1) & (S2[:, 0] != k) & (S2[:, 1] != k)
        assert not (inside & (gap < POINT_CLEARANCE_PX)).any()
    # each piece on an input segment (within the tolerance the snapping allows), the lengths adding up
    A0, B0 = U[S[:, 0]], U[S[:, 1]]
    D0 = B0 - A0
    for a, b in zip(A, B):
        mid = (a + b) / 2
        t = np.clip(((mid - A0) * D0).sum(1) / (D0 ** 2).sum(1), 0, 1)
        assert np.linalg.norm(A0 + t[:, None] * D0 - mid, axis=1).min() < POINT_CLEARANCE_PX
    assert abs(np.linalg.norm(B - A, axis=1).sum() - np.linalg.norm(D0, axis=1).sum()) < 0.5
    assert set(M2.tolist()) == {1, 2}


def test_points_in_polygon_matches_analytic_disc():
    th = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    P = np.stack([np.cos(th), np.sin(th)], 1) * 10
    rng = np.random.default_rng(0)
    Q = rng.uniform(-12, 12, (2000, 2))
    r = np.linalg.norm(Q, axis=1)
    got = points_in_polygon(Q, P)
    clear = np.abs(r - 10) > 0.01
    assert np.array_equal(got[clear], (r < 10)[clear])


def test_project_to_polyline_parameter():
    P = square(0, 0, 10)
    param, dist = project_to_polyline(np.array([[5.0, -1.0], [11.0, 2.5], [0.0, 0.0]]), P)
    assert np.allclose(param, [0.5, 1.25, 0.0])
    assert np.allclose(dist, [1.0, 1.0, 0.0])


def test_components():
    V1, F1 = triangulate([square(0, 0, 10)], 5.0)
    F = np.concatenate([F1, F1 + len(V1)])
    comp = vertex_components(2 * len(V1) + 1, F)
    assert len(np.unique(comp)) == 3


def test_degenerate_outer_raises():
    with pytest.raises(ValueError):
        triangulate([np.array([[0.0, 0.0], [1.0, 1.0], [0.0, 0.0]])], 1.0)


def test_face_stretch_is_one_for_rigid_motions_and_the_worst_scale_otherwise():
    rng = np.random.default_rng(3)
    rest = rng.uniform(0, 50, size=(30, 2))
    F = np.array([[i, i + 1, i + 2] for i in range(0, 27, 3)])
    c, s = np.cos(0.7), np.sin(0.7)
    rigid = rest @ np.array([[c, -s], [s, c]]).T + [5.0, -3.0]
    np.testing.assert_allclose(face_stretch(rest, rigid, F), 1.0, rtol=1e-9)
    np.testing.assert_allclose(face_stretch(rest, rest * [3.0, 1.0], F), 3.0, rtol=1e-9)  # stretched 3x
    np.testing.assert_allclose(face_stretch(rest, rest * [1.0, 0.25], F), 4.0, rtol=1e-9)  # squashed to 1/4
    shear = rest @ np.array([[1.0, 1.5], [0.0, 1.0]]).T
    sigma = np.linalg.svd(np.array([[1.0, 1.5], [0.0, 1.0]]), compute_uv=False)  # brute force: one matrix
    np.testing.assert_allclose(face_stretch(rest, shear, F), max(sigma[0], 1 / sigma[1]), rtol=1e-9)


def test_face_stretch_matches_the_svd_and_survives_degenerate_faces():
    rng = np.random.default_rng(5)
    rest = rng.uniform(0, 50, size=(60, 2))
    X = rest + rng.normal(scale=8.0, size=rest.shape)
    F = np.arange(60).reshape(20, 3)
    brute = []
    for f in F:
        E = np.stack([rest[f[1]] - rest[f[0]], rest[f[2]] - rest[f[0]]], 1)
        D = np.stack([X[f[1]] - X[f[0]], X[f[2]] - X[f[0]]], 1)
        s = np.linalg.svd(D @ np.linalg.inv(E), compute_uv=False)
        brute.append(max(s[0], 1 / s[1]))
    np.testing.assert_allclose(face_stretch(rest, X, F), brute, rtol=1e-7)
    flat = X.copy()
    flat[F[0, 2]] = 0.5 * (flat[F[0, 0]] + flat[F[0, 1]])  # collapsed to a line
    line_rest = rest.copy()
    line_rest[F[1, 2]] = line_rest[F[1, 0]]  # a degenerate rest face
    out = face_stretch(line_rest, flat, F)
    assert out[0] > 1e6 and np.isinf(out[1]) and np.isfinite(out[2:]).all()


def _edges(F):
    """(e, 2) sorted unique edges of faces F (m, 3)."""
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0)


def test_slit_is_made_of_mesh_edges_and_cut_opens_a_slot():
    """A slit inside the square: its edges are mesh edges; cutting copies every slit vertex but the two ends."""
    slit = np.array([[30.0, 50.0], [50.0, 50.0], [70.0, 50.0]])
    res = triangulate_pslg([square(0, 0, 100, 4)], max_area=30.0, slits=[slit])
    assert len(res.slit_edges) >= 2
    mesh_edges = {tuple(e) for e in _edges(res.F).tolist()}
    assert all(tuple(sorted(e)) in mesh_edges for e in res.slit_edges.tolist())
    on_slit = np.unique(res.slit_edges)
    V2, F2, origin = cut_along(res.V, res.F, res.slit_edges)
    assert len(V2) - len(res.V) == len(on_slit) - 2  # the slit's two ends keep one vertex: a slot, not a split
    np.testing.assert_array_equal(V2, res.V[origin])
    assert (signed_areas(V2, F2) > 0).all()
    # no face edge crosses the slot any more: the faces on both sides no longer share a slit edge
    e2, counts = np.unique(np.sort(np.concatenate([F2[:, [0, 1]], F2[:, [1, 2]], F2[:, [2, 0]]]), axis=1),
                           axis=0, return_counts=True)
    opened = {tuple(sorted(origin[e])) for e, c in zip(e2.tolist(), counts) if c == 1}
    assert {tuple(sorted(e)) for e in res.slit_edges.tolist()} <= opened
    assert vertex_components(len(V2), F2).max() == 0  # still one piece around the slot


def test_slit_from_outline_to_outline_splits_the_mesh():
    """A slit across the whole square, outline to outline, leaves two pieces, one on each side."""
    slit = np.array([[0.0, 50.0], [50.0, 50.0], [100.0, 50.0]])
    res = triangulate_pslg([square(0, 0, 100, 4)], max_area=30.0, slits=[slit])
    V2, F2, _ = cut_along(res.V, res.F, res.slit_edges)
    label = vertex_components(len(V2), F2)
    assert label.max() == 1
    for c in (0, 1):
        y = V2[label == c][:, 1]
        assert (y <= 50.0 + 1e-9).all() or (y >= 50.0 - 1e-9).all()


def test_densify_splits_every_edge_and_keeps_the_vertices_closed_or_open():
    from ops.geometry.polygon import densify

    P = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 3.0]])
    for closed in (True, False):
        D = densify(P, 1.0, closed=closed)
        steps = np.linalg.norm(np.diff(np.vstack([D, D[:1]]) if closed else D, axis=0), axis=1)
        assert steps.max() <= 1.0 + 1e-12 and steps.min() > 0
        assert all(np.isclose(D, v).all(axis=1).any() for v in P)  # every vertex kept, in order
        # closed: the edge back to the start (10.4 px) is split too, into 11; open: it ends on P's last vertex
        assert len(D) == (10 + 3 + 11 if closed else 10 + 3 + 1)
        assert np.allclose(D[-1], [10.0, 3.0]) != closed
