"""Constrained Delaunay triangulation of polygonal regions and mesh helpers (§4.2).

Coordinates are image pixels (x right, y down). Faces are oriented so that
`signed_areas` (the usual 0.5 * cross(e1, e2) on the raw numbers) is positive.

Input repairs (exact duplicate vertices merged, zero-length and repeated
segments dropped, degenerate loops dropped) happen BEFORE Triangle is called,
because Triangle crashes on duplicate vertices referenced by segments; every
repair is described in `MeshResult.warnings` (or appended to the `warnings`
list passed to `triangulate`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import triangle as tr
from scipy.spatial import cKDTree

from ops.geometry.polygon import points_in_polygon, project_to_polyline

# Coordinates closer than this (pixels) are treated as the same vertex.
_MERGE_GRID = 1e-7
# an extra point closer than this to a constraint segment is moved off it to this distance: a handle 2e-4 px
# from an occlusion region's loop made Triangle split the segment beside it into a flat sliver, and the template
# then dropped every contact slit of the drawing (one_girl_wave: the forearm stayed sewn to the skirt)
POINT_CLEARANCE_PX = 0.05
# Triangle inserts crossings of constraint segments itself, and meshes any input whose vertices keep this far
# from each other and from segments; closer than this it failed or crashed (see _planar)
DEGENERATE_PX = 1e-3
MAX_PLANAR_ROUNDS = 64  # rounds of _planar's splitting (each splits a segment at one crossing at most)


@dataclass
class MeshResult:
    """A triangulation and where its input points ended up."""

    V: np.ndarray  # (n, 2) float64 vertices, pixels
    F: np.ndarray  # (m, 3) int64 faces, positive signed area
    loop_vertex: list[np.ndarray]  # per input loop (n_i,) int64 mesh vertex of each loop point, -1 if dropped
    point_vertex: np.ndarray  # (p,) int64 mesh vertex of each extra point, -1 if dropped
    warnings: list[str] = field(default_factory=list)
    slit_edges: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))  # (e, 2) mesh edges on slits


def signed_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(m,) float64 signed areas of faces F (m, 3) over V (n, 2); positive = our orientation."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    e1, e2 = b - a, c - a
    return 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def face_stretch(rest: np.ndarray, X: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(m,) float64 worst scale of each face's affine map rest (n, 2) -> X (n, 2): max(sigma_max, 1 / sigma_min)
    of its Jacobian; 1 for a rigid motion, inf for a face collapsed to a line or a degenerate rest face."""
    e1, e2 = rest[F[:, 1]] - rest[F[:, 0]], rest[F[:, 2]] - rest[F[:, 0]]
    d1, d2 = X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]]
    det_e = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        # J = D E^-1 with E = [e1 e2], D = [d1 d2] (columns); its singular values in closed form
        a = (d1[:, 0] * e2[:, 1] - d2[:, 0] * e1[:, 1]) / det_e
        b = (d2[:, 0] * e1[:, 0] - d1[:, 0] * e2[:, 0]) / det_e
        c = (d1[:, 1] * e2[:, 1] - d2[:, 1] * e1[:, 1]) / det_e
        d = (d2[:, 1] * e1[:, 0] - d1[:, 1] * e2[:, 0]) / det_e
        frob, det = a * a + b * b + c * c + d * d, np.abs(a * d - b * c)
        root = np.sqrt(np.maximum(frob * frob - 4.0 * det * det, 0.0))
        s_max = np.sqrt(0.5 * (frob + root))
        s_min = det / s_max
        stretch = np.maximum(s_max, 1.0 / s_min)
    return np.where(np.isfinite(stretch), stretch, np.inf)


def edges_of(F: np.ndarray) -> np.ndarray:
    """(3m, 2) int64 directed half-edges (F[:,0]->F[:,1], F[:,1]->F[:,2], F[:,2]->F[:,0])."""
    return np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=0)


def boundary_loops(F: np.ndarray) -> list[np.ndarray]:
    """Boundary loops of the oriented mesh F (m, 3): list of (k,) int64 vertex cycles, longest first.

    A boundary half-edge is one whose reverse is absent; loops follow the
    faces' orientation. Pinched vertices (several outgoing boundary edges) are
    handled by consuming edges, so every boundary edge lies on exactly one loop.
    """
    E = edges_of(np.asarray(F, dtype=np.int64))
    if len(E) == 0:
        return []
    key = E[:, 0] * (E.max() + 1) + E[:, 1]
    rkey = E[:, 1] * (E.max() + 1) + E[:, 0]
    bnd = E[~np.isin(key, rkey)]
    # Repeated boundary half-edges (non-manifold sewing) are walked once each.
    out: dict[int, list[int]] = {}
    for a, b in bnd.tolist():
        out.setdefault(a, []).append(b)
    loops: list[np.ndarray] = []
    for start in sorted(out):
        while out.get(start):
            loop, v = [start], out[start].pop()
            while v != start and out.get(v):
                loop.append(v)
                v = out[v].pop()
            loops.append(np.asarray(loop, dtype=np.int64))
    loops.sort(key=len, reverse=True)
    return loops


def vertex_components(n: int, F: np.ndarray) -> np.ndarray:
    """(n,) int64 connected-component label of each vertex (isolated vertices get their own)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    E = edges_of(np.asarray(F, dtype=np.int64))
    A = coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    return connected_components(A, directed=False)[1].astype(np.int64)


def _clear_of_segments(P: np.ndarray, polylines: list[np.ndarray], closed: list[bool]) -> np.ndarray:
    """(p, 2) points P, each closer than POINT_CLEARANCE_PX to a segment of `polylines` moved straight away from
    it to that distance (a point on a segment: along the segment's normal). Points on a vertex stay: they merge."""
    P = P.copy()
    A = [L if c else L[:-1] for L, c in zip(polylines, closed)]
    B = [np.roll(L, -1, axis=0) if c else L[1:] for L, c in zip(polylines, closed)]
    if not len(P) or not A:
        return P
    A, B = np.concatenate(A), np.concatenate(B)
    AB = B - A
    L2 = np.maximum((AB ** 2).sum(axis=1), 1e-18)
    for i, p in enumerate(P):
        t = np.clip(((p - A) * AB).sum(axis=1) / L2, 0.0, 1.0)
        Q = A + t[:, None] * AB
        d = np.linalg.norm(p - Q, axis=1)
        j = int(d.argmin())
        if d[j] >= POINT_CLEARANCE_PX or min(np.linalg.norm(p - A[j]), np.linalg.norm(p - B[j])) < _MERGE_GRID:
            continue
        away = (p - Q[j]) / d[j] if d[j] > 1e-12 else np.array([-AB[j, 1], AB[j, 0]]) / np.sqrt(L2[j])
        P[i] = Q[j] + POINT_CLEARANCE_PX * away
    return P


def _merge_points(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact-duplicate merge (after snapping to a 1e-7 px grid): (unique (u, 2) in first-seen order, inverse (k,))."""
    key = np.round(P / _MERGE_GRID).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return P[first[order]], rank[inv.ravel()]


def _loop_segments(idx: list[np.ndarray], warnings: list[str]) -> np.ndarray:
    """(s, 2) int64 segments of closed loops given as merged vertex indices, zero-length/repeated removed."""
    segs = []
    for li, ix in enumerate(idx):
        s = np.stack([ix, np.roll(ix, -1)], axis=1)
        zero = s[:, 0] == s[:, 1]
        if zero.any():
            warnings.append(f"loop {li}: removed {int(zero.sum())} zero-length segment(s) (duplicate vertices)")
        segs.append(s[~zero])
    S = np.concatenate(segs, axis=0) if segs else np.zeros((0, 2), np.int64)
    _, keep = np.unique(np.sort(S, axis=1), axis=0, return_index=True)
    if len(keep) < len(S):
        warnings.append(f"removed {len(S) - len(keep)} repeated segment(s) shared by loops")
    return S[np.sort(keep)]


def _split_at(U: np.ndarray, S: np.ndarray, M: np.ndarray, cuts: dict[int, list[int]]
              ) -> tuple[np.ndarray, np.ndarray]:
    """Segments S (s, 2) with markers M (s,), each segment i in cuts split at the vertices cuts[i] of U (n, 2)
    (ordered along it) -> (S', M')."""
    out_s, out_m = [], []
    for i, (a, b) in enumerate(S.tolist()):
        if i not in cuts:
            out_s.append((a, b))
            out_m.append(M[i])
            continue
        d = U[b] - U[a]
        inner = sorted(set(cuts[i]) - {a, b}, key=lambda v: float((U[v] - U[a]) @ d))
        chain = [a, *inner, b]
        out_s += list(zip(chain[:-1], chain[1:]))
        out_m += [M[i]] * (len(chain) - 1)
    return np.asarray(out_s, np.int64).reshape(-1, 2), np.asarray(out_m, M.dtype)


def _cross(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    return p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0]


def _touches(U: np.ndarray, S: np.ndarray, tol: float) -> dict[int, list[int]]:
    """{segment of S (s, 2): the vertices of U (n, 2) within tol px of its interior (not its ends)}."""
    A, B = U[S[:, 0]], U[S[:, 1]]
    D = B - A
    L2 = np.maximum((D ** 2).sum(axis=1), 1e-18)
    lo, hi = np.minimum(A, B) - tol, np.maximum(A, B) + tol
    cuts: dict[int, list[int]] = {}
    # vertices in a segment's box, then within tol of its interior
    si, vi = np.nonzero((U[None, :, 0] >= lo[:, None, 0]) & (U[None, :, 0] <= hi[:, None, 0])
                        & (U[None, :, 1] >= lo[:, None, 1]) & (U[None, :, 1] <= hi[:, None, 1]))
    other = (vi != S[si, 0]) & (vi != S[si, 1])
    si, vi = si[other], vi[other]
    t = ((U[vi] - A[si]) * D[si]).sum(axis=1) / L2[si]
    gap = np.linalg.norm(U[vi] - (A[si] + t[:, None] * D[si]), axis=1)
    on = (t > 0) & (t < 1) & (gap < tol)
    for i, v in zip(si[on].tolist(), vi[on].tolist()):
        cuts.setdefault(i, []).append(v)
    return cuts


def _crossings(U: np.ndarray, S: np.ndarray, skip: set[int]) -> list[tuple[int, int, np.ndarray]]:
    """(i, j, point (2,)) for pairs of segments of S (s, 2) over U (n, 2) that cross properly and share no end,
    at most one per segment, segments in `skip` left out."""
    A, B = U[S[:, 0]], U[S[:, 1]]
    D = B - A
    lo, hi = np.minimum(A, B), np.maximum(A, B)
    i, j = np.nonzero(np.triu((hi[:, None, 0] >= lo[None, :, 0]) & (lo[:, None, 0] <= hi[None, :, 0])
                              & (hi[:, None, 1] >= lo[None, :, 1]) & (lo[:, None, 1] <= hi[None, :, 1]), k=1))
    apart = (S[i, 0] != S[j, 0]) & (S[i, 0] != S[j, 1]) & (S[i, 1] != S[j, 0]) & (S[i, 1] != S[j, 1])
    i, j = i[apart], j[apart]
    den = _cross(D[i], D[j])
    with np.errstate(divide="ignore", invalid="ignore"):
        ti = _cross(A[j] - A[i], D[j]) / den
        tj = _cross(A[j] - A[i], D[i]) / den
    hit = (den != 0) & (ti > 0) & (ti < 1) & (tj > 0) & (tj < 1)
    found, used = [], set(skip)
    for a, b, t in zip(i[hit].tolist(), j[hit].tolist(), ti[hit].tolist()):
        if a in used or b in used:
            continue  # one crossing per segment and round: its pieces are tested again
        used |= {a, b}
        found.append((a, b, A[a] + t * D[a]))
    return found


def _snap(U: np.ndarray, S: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices U (n, 2) closer than tol px to each other made one (the first of each cluster), segments S (s, 2)
    renumbered -> (U' (n', 2), S', index (n,) of each input vertex in U')."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pairs = cKDTree(U).query_pairs(tol, output_type="ndarray")
    if not len(pairs):
        return U, S, np.arange(len(U))
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(U), len(U)))
    label = connected_components(graph, directed=False)[1]
    first = np.full(label.max() + 1, len(U))
    np.minimum.at(first, label, np.arange(len(U)))
    kept = np.sort(first)
    rank = np.empty(len(U), np.int64)
    rank[kept] = np.arange(len(kept))
    index = rank[first[label]]
    return U[kept], index[S], index


def _degenerate(U: np.ndarray, S: np.ndarray, eps: float = DEGENERATE_PX) -> bool:
    """Whether two vertices of U (n, 2) lie within eps px of each other, or one within eps of a segment of S
    (s, 2) it does not end: the inputs Triangle's own segment insertion cannot be trusted with."""
    return bool(len(cKDTree(U).query_pairs(eps, output_type="ndarray")) or _touches(U, S, eps))


def _planar(U: np.ndarray, S: np.ndarray, M: np.ndarray, warnings: list[str], tol: float = POINT_CLEARANCE_PX
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A planar straight-line graph: vertices U (n, 2), segments S (s, 2), markers M (s,) -> (U', S', M', index
    (n,) of each input vertex in U') where no two vertices lie within tol px, no two segments cross and no vertex
    lies within tol of a segment it does not end.

    Used where the input is degenerate (_degenerate). Loops that cross or touch (overlapping occlusion regions,
    one painted per pair of bones) are legal input to Triangle, which inserts the crossings itself; but where a
    crossing falls on or a hair from another vertex, its own insertion failed ("topological inconsistency after
    splitting a segment"), once by a segmentation fault that no exception catches (the generator's true regions
    of held-out shots: one region's vertex on another region's edge, where that edge crosses the first region;
    two regions' vertices 6e-7 px apart). Here vertices within tol are merged, every segment is split at the
    vertices within tol of it, and each crossing is made a vertex (merged with one within tol), until none is
    left; a smaller tol makes Triangle refine around hair-thin features (1e-4 px: 55 000 faces instead of
    4 000). A segment made twice keeps the larger marker (a slit along a loop is still cut). Applied to every
    input instead, it moved the frames of 14 of 46 evaluated shots by up to 0.18 dB either way (a crossing
    Triangle would have inserted, made a vertex first, changes the mesh around it)."""
    U = np.asarray(U, np.float64)
    M = np.asarray(M).ravel()
    U, S, index = _snap(U, np.asarray(S, np.int64).reshape(-1, 2), tol)
    merged = len(index) - len(U)
    added = split = 0
    for _ in range(MAX_PLANAR_ROUNDS):
        keep = S[:, 0] != S[:, 1]
        S, M = S[keep], M[keep]
        cuts = _touches(U, S, tol)
        points: list[np.ndarray] = []
        for a, b, x in _crossings(U, S, set(cuts)):
            near = np.concatenate([U, np.asarray(points).reshape(-1, 2)])
            gap = np.linalg.norm(near - x, axis=1)
            v = int(gap.argmin())
            if gap[v] >= tol:
                v = len(near)
                points.append(x)
            cuts.setdefault(a, []).append(v)
            cuts.setdefault(b, []).append(v)
        if not cuts:
            break
        if points:
            U = np.concatenate([U, np.asarray(points)])
            added += len(points)
        split += len(cuts)
        S, M = _split_at(U, S, M, cuts)
    else:
        warnings.append(f"constraint segments still cross after {MAX_PLANAR_ROUNDS} rounds of splitting")
    if split or merged:
        key = np.sort(S, axis=1)
        order = np.lexsort((-M, key[:, 1], key[:, 0]))  # per repeated segment, the larger marker first
        _, first = np.unique(key[order], axis=0, return_index=True)
        keep = np.sort(order[first])
        S, M = S[keep], M[keep]
        warnings.append(f"made the constraint outlines planar: {merged} vertex(es) within {tol:g} px merged, "
                        f"{split} segment(s) split where they cross or pass within {tol:g} px of a vertex "
                        f"({added} crossing(s) made vertices)")
    return U, S, M, index


def _with_slit_ends(loops: list[np.ndarray], slits: list[np.ndarray], tol: float = 0.05) -> list[np.ndarray]:
    """The loops with every slit end that lies on one of their edges (within tol px, off its vertices) made a
    vertex of that loop. Triangle would otherwise split the edge at the end itself, and a slit meeting the
    outline at a hair's angle there made it fail ("topological inconsistency after splitting a segment"),
    once by a segmentation fault that no exception catches."""
    loops = list(loops)
    for end in [L[i] for L in slits if len(L) >= 2 for i in (0, -1)]:
        for k, L in enumerate(loops):
            if len(L) < 2 or np.linalg.norm(L - end, axis=1).min() <= tol:
                continue
            param, dist = project_to_polyline(end[None], L)
            if dist[0] <= tol:
                i = int(param[0])
                loops[k] = np.insert(L, i + 1, end, axis=0)
                break
    return loops


def triangulate_pslg(
    loops: list[np.ndarray],
    max_area: float,
    min_angle: float = 20.0,
    holes: np.ndarray | None = None,
    points: np.ndarray | None = None,
    n_domain: int = 1,
    slits: list[np.ndarray] | None = None,
) -> MeshResult:
    """CDT of the domain bounded by loops[:n_domain], with the other loops as constraints and extra vertices `points`.

    slits: open polylines (n_i, 2) inside the domain made of mesh edges too; MeshResult.slit_edges lists those
    edges (Triangle may split a slit's segments), for cut_along.

    loops: closed polylines (n_i, 2) float64 pixels, first != last. The first
    n_domain loops outline the domain (several components, and the outlines of
    its holes: a point is inside when it is inside an odd number of them); a
    loop containing a point of `holes` (k, 2) is a hole; the other loops stay
    as internal constraint edges. Extra points `points` (p, 2) outside the
    domain are dropped (point_vertex = -1) with a warning.
    """
    warnings: list[str] = []
    loops = [np.asarray(L, dtype=np.float64).reshape(-1, 2) for L in loops]
    pts = np.zeros((0, 2)) if points is None else np.asarray(points, dtype=np.float64).reshape(-1, 2)
    slits = [np.asarray(L, dtype=np.float64).reshape(-1, 2) for L in (slits or [])]
    if slits:
        loops = _with_slit_ends(loops, slits)
    pts = _clear_of_segments(pts, loops + slits, [True] * len(loops) + [False] * len(slits))
    sizes = [len(L) for L in loops]
    allp = np.concatenate(loops + slits + [pts], axis=0)
    U, inv = _merge_points(allp)
    offs = np.cumsum([0] + sizes)
    given = np.concatenate([inv[:offs[-1]], inv[len(allp) - len(pts):]])  # slits end on loop vertices on purpose
    merged = len(given) - len(np.unique(given))
    if merged:
        warnings.append(f"merged {merged} duplicate input vertex(es)")
    idx = [inv[offs[i]:offs[i + 1]] for i in range(len(loops))]
    if len(np.unique(idx[0])) < 3:
        raise ValueError("outer boundary loop has fewer than 3 distinct vertices")
    segs = _loop_segments(idx, warnings)
    off = offs[-1]
    slit_segs = []
    for L in slits:
        ix = inv[off:off + len(L)]
        off += len(L)
        slit_segs += [(a, b) for a, b in zip(ix[:-1], ix[1:]) if a != b]
    slit_segs = np.asarray(slit_segs, np.int64).reshape(-1, 2)
    markers = np.r_[np.ones(len(segs)), np.full(len(slit_segs), 2)].astype(np.int32)
    segs = np.concatenate([segs, slit_segs])
    if _degenerate(U, segs):
        U, segs, markers, planar_index = _planar(U, segs, markers, warnings)
        inv, idx = planar_index[inv], [planar_index[ix] for ix in idx]
    data = {"vertices": U, "segments": segs.astype(np.int32), "segment_markers": markers[:, None]}
    if holes is not None and len(holes):
        data["holes"] = np.asarray(holes, dtype=np.float64).reshape(-1, 2)
    out = tr.triangulate(data, f"pq{min_angle:g}a{max_area:.12g}Q")
    V = np.asarray(out["vertices"], dtype=np.float64)
    F = np.asarray(out.get("triangles", np.zeros((0, 3))), dtype=np.int64)
    V, F, new_of_old = _clean(V, F, loops[:n_domain], warnings)
    vmap = new_of_old[: len(U)]
    loop_vertex = [vmap[ix] for ix in idx]
    point_vertex = vmap[inv[off:]]
    if (point_vertex < 0).any():
        warnings.append(f"{int((point_vertex < 0).sum())} extra point(s) outside the meshed region dropped")
    slit_edges = np.zeros((0, 2), np.int64)
    if len(slit_segs):
        out_segs = np.asarray(out["segments"], np.int64).reshape(-1, 2)
        on_slit = np.asarray(out["segment_markers"]).ravel() == 2
        slit_edges = new_of_old[out_segs[on_slit]]
        slit_edges = slit_edges[(slit_edges >= 0).all(axis=1)]
    return MeshResult(V, F, loop_vertex, point_vertex, warnings, slit_edges)


def cut_along(V: np.ndarray, F: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Open the mesh along (e, 2) interior edges: (V', F', origin (n',) int64 vertex of V each vertex copies).

    Around every vertex of a cut edge, the incident faces fall into groups that meet across edges not cut;
    the first group keeps the vertex and each other group gets a copy. A cut that ends inside the mesh closes
    there (its end vertex keeps one group), so a slit is a slot; one that reaches the boundary frees a flap.
    """
    V = np.asarray(V, np.float64)
    cut = {tuple(sorted(e)) for e in np.asarray(edges, np.int64).reshape(-1, 2).tolist()}
    if not cut:
        return V, np.asarray(F, np.int64).copy(), np.arange(len(V))
    F, origin = split_fans(F, len(V), sorted({v for e in cut for v in e}), cut)
    return V[origin], F, origin


def split_fans(F: np.ndarray, n: int, vertices, cut: set[tuple[int, int]] = frozenset()
               ) -> tuple[np.ndarray, np.ndarray]:
    """Give each fan of faces around each of `vertices` its own vertex: (F', origin (n',) int64 vertex of the n
    each vertex copies). A fan is the faces around the vertex that meet across its edges not in `cut`
    ((a, b) with a < b); the first keeps the vertex.

    With no cut this splits pinches: two sheets that touch at a single vertex (where two cuts meet end to
    end: a slit from a T-junction and the region's cut that stops there) are apart, not hinged there."""
    F = np.asarray(F, np.int64).copy()
    wanted = np.unique(np.asarray(list(vertices), np.int64))
    incident: dict[int, list[int]] = {int(v): [] for v in wanted}
    for f in np.nonzero(np.isin(F, wanted).any(axis=1))[0].tolist():
        for v in F[f].tolist():
            if v in incident:
                incident[v].append(f)
    origin = list(range(n))
    for v, faces in incident.items():
        parent = {f: f for f in faces}

        def find(f):
            while parent[f] != f:
                parent[f] = parent[parent[f]]
                f = parent[f]
            return f

        by_edge: dict[tuple, int] = {}
        for f in faces:
            for w in F[f].tolist():
                if w == v:
                    continue
                e = (min(v, w), max(v, w))
                if e in cut:
                    continue
                if e in by_edge:
                    parent[find(f)] = find(by_edge[e])
                else:
                    by_edge[e] = f
        groups: dict[int, list[int]] = {}
        for f in faces:
            groups.setdefault(find(f), []).append(f)
        for g in list(groups.values())[1:]:
            copy = len(origin)
            origin.append(v)
            for f in g:
                F[f][F[f] == v] = copy
    return F, np.asarray(origin, np.int64)


def points_in_domain(Q: np.ndarray, loops: list[np.ndarray]) -> np.ndarray:
    """(k,) bool: points Q (k, 2) inside an odd number of the closed polylines (outlines and their holes)."""
    inside = np.zeros(len(Q), bool)
    for L in loops:
        inside ^= points_in_polygon(Q, L)
    return inside


def _clean(V: np.ndarray, F: np.ndarray, domain: list[np.ndarray], warnings: list[str]):
    """Orient faces positively, drop faces outside the domain and unused vertices: (V, F, new index of each old vertex)."""
    a = signed_areas(V, F)
    neg = a < 0
    F = F.copy()
    F[neg] = F[neg][:, [0, 2, 1]]
    # Constraint loops poking outside the outer boundary would shield exterior triangles from Triangle's eating.
    inside = points_in_domain(V[F].mean(axis=1), domain) & (np.abs(a) > 0)
    if not inside.all():
        warnings.append(f"dropped {int((~inside).sum())} face(s) outside the outer boundary or degenerate")
    F = F[inside]
    used = np.zeros(len(V), bool)
    used[F.ravel()] = True
    new = np.full(len(V), -1, np.int64)
    new[used] = np.arange(used.sum())
    return V[used], new[F], new


def triangulate(
    loops: list[np.ndarray],
    max_area: float,
    min_angle: float = 20.0,
    holes: np.ndarray | None = None,
    warnings: list[str] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """CDT of the region bounded by closed polylines: (V (n, 2) float64 pixels, F (m, 3) int64, positive area).

    loops[0] is the outer boundary, loops[1:] are holes (if a point of `holes`
    lies inside) or internal constraint loops whose edges appear as mesh edges.
    Repairs of the input (merged duplicates, removed zero-length segments) are
    appended to `warnings` if a list is given. Input vertices keep their
    positions; see `triangulate_pslg` for the input-to-mesh vertex map.
    """
    res = triangulate_pslg(loops, max_area, min_angle, holes)
    if warnings is not None:
        warnings.extend(res.warnings)
    return res.V, res.F
