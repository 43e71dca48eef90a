"""The stages are declared without Dagster (assets/compute.py, assets/stages.py), so a run computes them while
Dagster loads; the Dagster assets are made from the same declarations."""
from __future__ import annotations

import subprocess
import sys

from assets.compute import RESOURCE_MODULES, STAGE_SPECS
from assets.graph import union_graph


def test_declaring_every_stage_imports_neither_dagster_nor_torch():
    code = ("import sys\nimport assets.stages\nfrom assets.compute import STAGE_SPECS\n"
            "assert len(STAGE_SPECS) > 100, len(STAGE_SPECS)\n"
            "bad = [m for m in ('dagster', 'torch', 'pandas') if m in sys.modules]\n"
            "assert not bad, bad\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_the_declarations_are_the_graph_and_the_dagster_assets():
    from assets import definitions
    from assets.resource_types import RESOURCE_TYPES

    assert set(STAGE_SPECS) == set(union_graph())
    assert {"/".join(k.path) for a in definitions.STAGE_ASSETS for k in a.keys} == set(STAGE_SPECS)
    assert {k: t.__module__ for k, t in RESOURCE_TYPES.items()} == RESOURCE_MODULES


def _ordered_by_scanning(parents: dict[str, tuple[str, ...]]) -> tuple[str, ...]:
    """The definition, brute force: repeatedly take the first stage in the table whose parents are placed."""
    done: list[str] = []
    while len(done) < len(parents):
        done.append(next(n for n in parents if n not in done
                          and all(p in done or p not in parents for p in parents[n])))
    return tuple(done)


def test_the_topological_order_is_the_scanning_definitions_on_random_graphs_and_every_shot_size():
    import random

    from assets.graph import shot_graph, topological

    rng = random.Random(7)
    for _ in range(200):
        names = [f"s{i}" for i in range(rng.randint(1, 30))]
        rng.shuffle(names)
        rank = {n: i for i, n in enumerate(sorted(names))}  # a hidden order that makes the graph acyclic
        table = {n: tuple(rng.sample([m for m in names if rank[m] < rank[n]] + ["outside"],
                                     k=min(3, rank[n] + 1))) for n in names}
        assert topological(table) == _ordered_by_scanning(table)
    for n in (1, 2, 3, 16):
        assert shot_graph(n).all_stages == _ordered_by_scanning(shot_graph(n).parents)


def test_a_shots_definitions_make_only_its_own_assets():
    code = ("from assets import definitions as d\nfrom assets.graph import shot_graph\n"
            "g = shot_graph(2)\n"
            "defs = d.shot_definitions(g.all_stages, g.sources)\n"
            "assert d._stage.cache_info().currsize == len(g.all_stages), d._stage.cache_info()\n"
            "assert d._source.cache_info().currsize == len(g.sources), d._source.cache_info()\n"
            "assert len(d.STAGE_ASSETS) > 100\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
