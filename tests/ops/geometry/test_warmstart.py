"""Tests of ops.geometry.warmstart: a deformation carried from one cut topology to its neighbour."""
import numpy as np

from ops.geometry.deform import Deformer, count_flipped
from ops.geometry.template import build_template
from ops.geometry.topology import cusp_assignment, cusp_stretches, evaluate, handle_path
from ops.geometry.warmstart import transfer_positions
from tests.ops.geometry.test_template import capsule_scene


def _path(base, sk, p0, p1):
    return handle_path(base, p0, p1, sk.parents)


def test_warm_start_carries_a_solution_between_cuts():
    refined, sk, p0, p1 = capsule_scene(junctions=(5,))
    base = build_template(refined, p0, sk)
    path = _path(base, sk, p0, p1)
    stretch = cusp_stretches(20, base.junctions[0])[0]
    here, next_to = (cusp_assignment(base.junctions[0], int(c), 0) for c in stretch[8:10])
    _, inc0, steps0, _ = evaluate(base, [here], path)
    x0 = steps0[-1][0]
    # onto its own topology the transfer is exact
    assert np.array_equal(transfer_positions(x0, inc0.faces, inc0.faces, inc0.rest), x0)
    # the cusp one vertex on: fold-free, and solved from there at the other pose alone it reaches the energy
    # the whole path from rest reaches, in a fraction of the iterations
    e1, inc1, *_ = evaluate(base, [next_to], path)
    start = transfer_positions(x0, inc0.faces, inc1.faces, inc1.rest)
    assert count_flipped(start, inc1.faces) == 0
    d = Deformer(inc1.rest, inc1.faces, inc1.handles)
    warm, cold = d.solve(path[-1], x0=start), d.solve_along(path)
    assert np.isclose(warm.energy, e1, rtol=1e-4) and np.isclose(cold.energy, e1)
    assert warm.iterations < cold.iterations
    # every vertex all of whose corners had one source keeps that source's position
    src = {}
    for f0, f1 in zip(inc0.faces, inc1.faces):
        for u, v in zip(f0, f1):
            src.setdefault(int(v), set()).add(int(u))
    single = [v for v, us in src.items() if len(us) == 1]
    assert np.array_equal(start[single], x0[[next(iter(src[v])) for v in single]])


def _transfer_by_scan(x_from, faces_from, faces_to, rest_to):
    """The rule written plainly: one source: its position; several: in vertex order, the source that folds the
    fewest of the vertex's faces (the earlier vertices already placed, the later at their first source)."""
    sources = {}
    for f0, f1 in zip(faces_from.tolist(), faces_to.tolist()):
        for u, v in zip(f0, f1):
            sources.setdefault(v, set()).add(u)
    x = np.array(rest_to, dtype=np.float64)
    for v, us in sources.items():
        x[v] = x_from[min(us)]
    for v in sorted(v for v, us in sources.items() if len(us) > 1):
        around = faces_to[(faces_to == v).any(axis=1)]
        folds = {}
        for u in sorted(sources[v]):
            x[v] = x_from[u]
            e1, e2 = x[around[:, 1]] - x[around[:, 0]], x[around[:, 2]] - x[around[:, 0]]
            folds[u] = int((e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] <= 0).sum())
        x[v] = x_from[min(folds, key=lambda u: (folds[u], u))]
    return x


def test_transfer_matches_the_rule_on_random_incisions():
    # a mesh whose random corners are re-pointed to copies of their vertex (as another incision's sheets), the
    # copies displaced: vertices with two sources, some whose choice folds faces
    refined, sk, p0, p1 = capsule_scene(junctions=(5,))
    base = build_template(refined, p0, sk)
    faces, rest = base.F, base.V
    rng = np.random.default_rng(7)
    for _ in range(5):
        split = rng.choice(len(rest), 25, replace=False)
        copy_of = {int(v): len(rest) + i for i, v in enumerate(split)}
        faces_from = faces.copy()
        for f, c in zip(*np.nonzero((rng.random(faces.shape) < 0.5) & np.isin(faces, split))):
            faces_from[f, c] = copy_of[int(faces[f, c])]
        x_from = np.concatenate([rest, rest[split]]) + rng.normal(0, 1.5, (len(rest) + len(split), 2))
        got = transfer_positions(x_from, faces_from, faces, rest)
        assert np.array_equal(got, _transfer_by_scan(x_from, faces_from, faces, rest))
        assert len({v for v in split.tolist() if (faces_from == copy_of[v]).any() and (faces_from == v).any()}) > 5
