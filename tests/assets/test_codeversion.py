"""Stage code versions come from the code a stage runs (issue 14): edits inside the closure change them, edits
outside do not, and a new module imported by an op is covered without touching assets/."""
from __future__ import annotations

import ast
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from assets import definitions  # noqa: F401  (defines the stages)
from assets.codeversion import ROOT, ImportGraph, code_record, code_version
from assets.compute import STAGE_SPECS

BASE = ImportGraph()


def edited(relpath: str) -> ImportGraph:
    """The import graph with one line appended to one file (the file on disk is untouched)."""
    return BASE.reading(lambda p: p.read_bytes() + (b"\n# an edit\n" if p == ROOT / relpath else b""))


def version_after_edit(stage: str, relpath: str) -> str:
    spec = STAGE_SPECS[stage]
    return code_version(code_record(spec.functions, spec.resource_modules, edited(relpath)))


def file_of(symbol: str, package: str = "ops") -> str:
    """Relative path of the module that defines `symbol` (found by reading the sources, not from a list)."""
    hits = [p for p in (ROOT / package).rglob("*.py")
            if any(isinstance(n, (ast.FunctionDef, ast.ClassDef)) and n.name == symbol
                   for n in ast.parse(p.read_text()).body)]
    assert len(hits) == 1, f"{symbol} defined in {hits}"
    return hits[0].relative_to(ROOT).as_posix()


def stale_after_edit(relpath: str) -> set[str]:
    return {n for n, s in STAGE_SPECS.items() if version_after_edit(n, relpath) != code_version(s.code)}


def test_done_when_examples():
    snap = stale_after_edit(file_of("snap_into"))
    assert {"key0/refined_masks", "key1/refined_masks"} <= snap and "key0/masks" not in snap
    mesh = stale_after_edit(file_of("vertex_components"))
    assert {"seg0/key0/textured_template", "seg0/key0/deformed_frames", "seg0/key1/deformed_frames"} <= mesh
    assert "key0/masks" not in mesh
    for network_code in ("IFNet", "blend_rgba"):  # the network (torch), the NumPy runtime around its export
        rife = stale_after_edit(file_of(network_code))
        assert "seg0/rife_matrix" in rife and not {"key0/masks", "key0/template"} & rife


def _ast_imports(path: Path, module: str) -> set[str]:
    """Brute force: every project module named by an import statement of a file, anywhere in it."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_bytes())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            out |= {base} | {f"{base}.{a.name}" for a in node.names}
    return {m for m in out if BASE.path(m) is not None}


def test_every_stage_changes_exactly_with_its_import_closure():
    """For every stage and every project module: an edit changes the version iff the module is reachable
    from the stage's code, by a brute-force walk of import statements (independent of grimp)."""
    modules = sorted(m for m in BASE.graph.modules if BASE.path(m) is not None)
    imports = {m: _ast_imports(BASE.path(m), m) for m in modules}
    # one stage per compute function's code: every key's and segment's copy of a stage runs the same code
    distinct = {spec.compute.__code__: (name, spec) for name, spec in STAGE_SPECS.items()}
    assert len(distinct) <= 20 < len(STAGE_SPECS)
    for name, spec in distinct.values():
        from assets.codeversion import function_references

        roots, _ = function_references(spec.functions)
        reach, todo = set(), [m for m in roots | set(spec.resource_modules) if m in imports]
        while todo:
            m = todo.pop()
            if m not in reach:
                reach.add(m)
                todo += imports[m]
        before = code_version(spec.code)
        for m in modules:
            changed = version_after_edit(name, BASE.relpath(m)) != before
            assert changed == (m in reach), f"{name}: editing {m} {'changes' if changed else 'keeps'} its version"
        assert "ops/types.py" in spec.code or name.endswith("/quality_metrics")  # dataclass layouts are part of it


def test_own_function_edit_is_code_change_and_closure_is_fast():
    start = time.process_time()  # CPU time: other processes on the machine do not count
    graph = ImportGraph()
    # every key's lane runs the same code: one record per compute function's code, as the stages get them
    distinct = {s.compute.__code__: s for s in STAGE_SPECS.values()}
    by_code = {c: code_record(s.functions, s.resource_modules, graph) for c, s in distinct.items()}
    assert time.process_time() - start < 1.0  # ~25 ms measured; generous on a slow CI machine
    records = {n: by_code[s.compute.__code__] for n, s in STAGE_SPECS.items()}
    assert records == {n: s.code for n, s in STAGE_SPECS.items()}
    assert all(r["<functions>"] for r in records.values())


@pytest.mark.slow
def test_new_ops_module_imported_by_an_op_is_covered(tmp_path):
    """In a copy of the project: a new module imported by ops/geometry/mesh.py joins the closure of every stage
    that runs the mesh code, with no change to assets/."""
    for pkg in ("assets", "ops", "resources"):
        shutil.copytree(ROOT / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "ops" / "geometry" / "newhelper.py").write_text("SCALE = 2.0\n")
    mesh = tmp_path / "ops" / "geometry" / "mesh.py"
    mesh.write_text(mesh.read_text().replace("import numpy as np\n", "import numpy as np\n\nfrom ops.geometry import newhelper  # noqa: F401\n", 1))
    script = ("import json, warnings; warnings.filterwarnings('ignore'); from assets.run.planning import _import_code_records; "
              "print(json.dumps(_import_code_records()))")
    out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, check=True,
                         env={"PATH": "/usr/bin:/bin", "INBETWEEN_HOME": str(tmp_path / "home"), "PYTHONPATH": str(tmp_path)})
    records = json.loads(out.stdout.strip().splitlines()[-1])
    has = {n for n, r in records.items() if "ops/geometry/newhelper.py" in r}
    assert {"key0/refined_masks", "key0/template", "seg0/key0/textured_template", "seg0/key1/deformed_frames"} <= has
    assert "key0/masks" not in has and "seg0/rife_matrix" not in has
