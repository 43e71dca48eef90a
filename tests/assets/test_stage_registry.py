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
