"""Security (issue 10): servers bind to loopback, weights load without unpickling code, nothing pickles user data.

Static: the project's sources never import a pickle module, never call torch.load without weights_only=True,
np.load with allow_pickle=True, pandas.read_pickle or an unsafe YAML loader, and never name 0.0.0.0.
Dynamic: a RIFE weights file that would run code when unpickled is refused without running it; after a
run, nothing under INBETWEEN_HOME is a pickle: the store's files and Dagster's SQLite rows (run bodies,
the event log with our metadata) are JSON, arrays load with allow_pickle=False.
"""
from __future__ import annotations

import ast
import json
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from assets.cli import main
from ops.errors import ShotError

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("assets", "ops", "resources", "editor", "benchmarks", "data_samples")
PICKLERS = {"pickle", "cPickle", "_pickle", "dill", "cloudpickle", "shelve", "marshal", "joblib"}
PICKLE_MAGIC = (b"\x80\x02", b"\x80\x03", b"\x80\x04", b"\x80\x05")


def _sources():
    for pkg in PACKAGES:
        yield from sorted((ROOT / pkg).rglob("*.py")) if (ROOT / pkg).is_dir() else ()


def _dotted(node) -> str:
    if isinstance(node, ast.Attribute):
        return f"{_dotted(node.value)}.{node.attr}"
    return node.id if isinstance(node, ast.Name) else ""


def _keyword(call: ast.Call, name: str):
    for kw in call.keywords:
        if kw.arg == name:
            return kw.value.value if isinstance(kw.value, ast.Constant) else "<expr>"
    return None


def problems(path: Path) -> list[str]:
    """What in this source file could unpickle untrusted data or expose a server."""
    tree = ast.parse(path.read_text(), str(path))
    out = []
    for node in ast.walk(tree):
        where = f"{path.relative_to(ROOT)}:{getattr(node, 'lineno', 0)}"
        if isinstance(node, ast.Import | ast.ImportFrom):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            out += [f"{where}: imports {n}" for n in names if n.split(".")[0] in PICKLERS]
        elif isinstance(node, ast.Call):
            fn = _dotted(node.func)
            if fn.endswith("torch.load") and _keyword(node, "weights_only") is not True:
                out.append(f"{where}: torch.load without weights_only=True")
            if fn.split(".")[-1] == "load" and fn.split(".")[0] in ("np", "numpy") and _keyword(node, "allow_pickle") not in (None, False):
                out.append(f"{where}: np.load with allow_pickle")
            if fn.endswith("read_pickle") or fn.endswith("unsafe_load"):
                out.append(f"{where}: {fn}")
            if fn.endswith("yaml.load") and "Safe" not in str(_keyword(node, "Loader")):
                out.append(f"{where}: yaml.load without a safe loader")
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.strip() in ("0.0.0.0", "::"):
            out.append(f"{where}: binds every interface ({node.value!r})")
    return out


def test_sources_never_unpickle_or_bind_every_interface():
    files = list(_sources())
    assert len(files) > 40
    found = [p for f in files for p in problems(f)]
    assert found == []


def test_the_scan_finds_what_it_looks_for(tmp_path):
    """The scanner itself can fail: a file with each forbidden thing is caught."""
    bad = ROOT / "ops" / "_scan_probe.py"
    bad.write_text("import pickle\nimport numpy as np\nimport torch\ntorch.load('w')\nnp.load('a', allow_pickle=True)\n"
                   "import pandas as pd\npd.read_pickle('x')\nHOST = '0.0.0.0'\n")
    try:
        found = problems(bad)
    finally:
        bad.unlink()
    assert len(found) == 5, found


def test_ui_binds_to_loopback(monkeypatch, tmp_path):
    calls = []
    monkeypatch.setenv("INBETWEEN_HOME", str(tmp_path / "home"))
    # `ui` replaces this process with Dagster's (os.execv): a test that misses that runs `dagster dev` in pytest's place
    monkeypatch.setattr("os.execv", lambda exe, argv: calls.append(argv))
    monkeypatch.setattr("os.execvp", lambda exe, argv: pytest.fail(f"ui must exec this interpreter, not PATH's: {argv}"))
    assert main(["ui"]) == 0
    argv = calls[0]
    assert argv[1:4] == ["-m", "dagster", "dev"] and argv[argv.index("-h") + 1] == "127.0.0.1"


def test_weights_that_would_run_code_are_refused_without_running_it(tmp_path):
    torch = pytest.importorskip("torch")
    from ops.blending.rife import load_rife

    marker = tmp_path / "pwned"

    class Payload:
        def __reduce__(self):
            return (Path.touch, (marker,))

    weights = tmp_path / "flownet.pkl"
    torch.save({"block0.conv0.0.0.weight": Payload()}, weights)
    with pytest.raises(ShotError) as e:
        load_rife(weights)
    assert not marker.exists()  # weights_only=True: the payload was never called
    assert "\n" not in str(e.value) and "state dict" in str(e.value)


def _rows(db: Path, table: str, column: str):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        if not con.execute("select 1 from sqlite_master where type='table' and name=?", (table,)).fetchone():
            return []
        return [r[0] for r in con.execute(f"select {column} from {table}")]
    finally:
        con.close()


@pytest.mark.slow
def test_nothing_under_the_home_is_a_pickle(warm, tmp_path):
    from assets.run import run_shot

    warm.forget_dagster_record()  # a run that writes Dagster's event log with our metadata
    run_shot(warm.shot, tmp_path / "out")
    files = [f for f in warm.home.rglob("*") if f.is_file()]
    assert any(f.suffix == ".npz" for f in files) and any(f.suffix == ".db" for f in files)
    for f in files:
        with open(f, "rb") as fh:
            assert fh.read(2) not in PICKLE_MAGIC, f
        if f.suffix == ".npz":
            with np.load(f, allow_pickle=False) as z:
                assert all(z[k].dtype != object for k in z.files), f
        if f.name.endswith(".json"):
            json.loads(f.read_text())
    checked = 0
    for db in warm.home.rglob("*.db"):
        for event in _rows(db, "event_logs", "event"):
            json.loads(event)  # Dagster's serdes: JSON, with our metadata (previews, counts, provenance) inside
            checked += 1
        for body in _rows(db, "runs", "run_body"):
            json.loads(body)
            checked += 1
    assert checked > 20
