"""Stage code versions derived from the code a stage runs, never from a hand-kept list (issue 14).

What a stage runs: its compute function, the helper functions of its own
module that it calls (their source text), the project modules they reference
(ops.*, resources.*) and the modules of the resources it declares, closed
under imports within the project. The import graph comes from grimp, which
reads every import statement (one inside a function counts as well), so a new
ops module imported by a stage's op is covered without touching assets/. The
graph is built once per process (about 10 ms) and the records of all stages
cost a few ms more.

ops/types.py, the dataclasses passed between stages, belongs to every closure
that imports it, on purpose: the store writes dataclasses field by field
(resources/store.py), so a changed dataclass can make an old output
unreadable or change what its fields mean. Settings are not code: a stage
records the values of the settings it read (ops/settings.py).

A stage's code record is {module file: sha256 of its source}, plus one entry
for its own functions; the code version (the asset's `code_version` in the
Dagster UI) is the hash of that record, and a change names the files that
changed ("code changed: ops/geometry/mesh.py").
"""
from __future__ import annotations

import hashlib
import inspect
import sys
import types
from collections.abc import Callable, Iterable
from functools import cache, lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PROJECT = ("ops", "resources")  # packages whose modules are stage code; assets/ is covered function by function


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


class ImportGraph:
    """Imports between the project's modules (grimp reads them from the source, nothing is imported),
    and the source hash of each module."""

    def __init__(self, root: Path = ROOT, read: Callable[[Path], bytes] | None = None, graph=None):
        """root: the repository; read: how to read a source file (tests patch it to simulate edits)."""
        import grimp

        self.root = root
        self.read = read or (lambda p: p.read_bytes())
        self.graph = graph or grimp.build_graph(*PROJECT, cache_dir=None)  # every import, function-level ones too
        self._hashes: dict[str, str] = {}

    def reading(self, read: Callable[[Path], bytes]) -> ImportGraph:
        """The same import graph with sources read by `read` (an edit simulated without touching files)."""
        return ImportGraph(self.root, read, self.graph)

    def path(self, module: str) -> Path | None:
        """Source file of a project module ('ops.geometry.mesh'), or None if it is not one."""
        if module.split(".")[0] not in PROJECT:
            return None
        base = self.root.joinpath(*module.split("."))
        for p in (base.with_suffix(".py"), base / "__init__.py"):
            if p.is_file():
                return p
        return None

    def closure(self, roots: Iterable[str]) -> frozenset[str]:
        """Every project module reachable from `roots` through imports (roots included)."""
        roots = {m for m in roots if m in self.graph.modules}
        return frozenset(roots.union(*(self.graph.find_upstream_modules(m) for m in roots)))

    def relpath(self, module: str) -> str:
        return self.path(module).relative_to(self.root).as_posix()

    def source_hash(self, module: str) -> str:
        if module not in self._hashes:
            self._hashes[module] = _digest(self.read(self.path(module)))
        return self._hashes[module]


def _code_objects(code: types.CodeType):
    yield code
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            yield from _code_objects(c)


def _referenced(fn: Callable) -> list:
    """Objects a function refers to by name: its globals and closure cells that its code (nested code too) names."""
    names = {n for code in _code_objects(fn.__code__) for n in code.co_names}
    found = [fn.__globals__[n] for n in names if n in fn.__globals__]
    for cell in fn.__closure__ or ():
        try:
            found.append(cell.cell_contents)
        except ValueError:  # an empty cell: a name the enclosing function binds later
            pass
    return found


def function_references(fns: Iterable[Callable]) -> tuple[set[str], list[Callable]]:
    """(project modules referenced, every function followed) from `fns` and the same-module helpers they call."""
    modules: set[str] = set()
    todo, seen = list(fns), []
    while todo:
        fn = todo.pop()
        if fn in seen or fn.__code__.co_filename != getattr(sys.modules.get(fn.__module__), "__file__", None):
            continue  # generated code (a dataclass's __init__) has no source of its own
        seen.append(fn)
        for obj in _referenced(fn):
            mod = obj.__name__ if isinstance(obj, types.ModuleType) else getattr(obj, "__module__", None)
            if mod and mod.split(".")[0] in PROJECT:
                modules.add(mod)
            if isinstance(obj, types.FunctionType) and obj.__module__ == fn.__module__:
                todo.append(obj)  # a helper of the asset module: its source and references count too
            elif isinstance(obj, type) and obj.__module__ == fn.__module__:
                todo.extend(v for v in vars(obj).values() if isinstance(v, types.FunctionType))
    return modules, seen


@lru_cache(maxsize=1)
def default_graph() -> ImportGraph:
    return ImportGraph()


def code_record(fns: Iterable[Callable], resource_modules: Iterable[str] = (),
                graph: ImportGraph | None = None) -> dict[str, str]:
    """{file: source hash} of everything the functions run, plus '<functions>' for their own source text."""
    graph = graph or default_graph()
    modules, followed = function_references(fns)
    closure = graph.closure(modules | set(resource_modules))
    record = {graph.relpath(m): graph.source_hash(m) for m in sorted(closure)}
    own = "\n".join(_function_source(f) for f in sorted(followed, key=lambda f: (f.__module__, f.__qualname__)))
    record["<functions>"] = _digest(own.encode())
    return record


@cache
def _function_source(fn: Callable) -> str:
    return f"{fn.__module__}.{fn.__qualname__}\n{inspect.getsource(fn)}"


def code_version(record: dict[str, str]) -> str:
    """One hash for a code record (the asset's code_version)."""
    return _digest("\n".join(f"{k}={v}" for k, v in sorted(record.items())).encode())


def changed_files(old: dict[str, str], new: dict[str, str]) -> list[str]:
    """Files whose source differs between two code records, or that entered or left the closure."""
    return sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))


def project_fingerprint(root: Path = ROOT) -> str:
    """Hash of every Python source of the project (assets/, ops/, resources/): cached code records stay valid
    exactly as long as this does."""
    h = hashlib.sha256()
    for pkg in ("assets", *PROJECT):
        for p in sorted((root / pkg).rglob("*.py")):
            h.update(p.relative_to(root).as_posix().encode())
            h.update(p.read_bytes())
    return h.hexdigest()[:16]
