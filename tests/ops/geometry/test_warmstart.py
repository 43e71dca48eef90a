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
