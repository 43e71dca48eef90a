"""Where stage outputs live: one directory per (shot partition, stage), written atomically. No Dagster here.

Layout: <root>/<partition>/<asset/key/path>/ holding
  meta.json    dataclass type, scalar fields, content hash, provenance, file sizes (written last)
  arrays.npz   every numpy array field (lists of arrays as name.0, name.1, ...)
  <field>.exr  image fields (float, lossless) through OpenImageIO
  table.parquet + table.csv  for pandas DataFrames
A stage is written into a temporary sibling directory and renamed into place,
so a killed run never leaves a half-written output that a rerun would trust.
The writing may happen ahead of the rename (`Store.stage`, from the thread
that computed the output): the IO manager's `write` of the same output then
only renames it into place.

The provenance a stage records (its parents' data versions, the settings it
read, its code version) lives in the same meta.json, so an output and the
record of what produced it are replaced together, and freshness can be decided
from the files alone (assets/provenance.py), without starting Dagster. The
size of every file is recorded too: a truncated or deleted file makes the
output "damaged", which is recomputed, never trusted.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import sys
import threading
import uuid
from pathlib import Path
from typing import Any

import numpy as np

from ops import types as T
from ops.shotio.image_io import read_image, write_image
from ops.shotio.npz import read_npz

# fields stored as images (H, W, C) float32 via OpenImageIO; stacks (N, H, W, C) as one file per image
IMAGE_FIELDS = {"texture", "back_texture", "images", "frames"}
SLAB_MIN_BYTES = 1 << 20  # arrays smaller than this are stored and hashed whole (filled_slabs)
_TYPES = {cls.__name__: cls for cls in vars(T).values() if dataclasses.is_dataclass(cls) and isinstance(cls, type)}


def _is_table(value: Any) -> bool:
    """A pandas DataFrame? Told by its class, without touching pandas: pandas is imported only where tables
    are read (an unchanged rerun never needs it), and an idle worker may be importing it on another thread
    right now, when sys.modules already holds the half-initialized module (no DataFrame attribute yet)."""
    cls = type(value)
    return cls.__name__ == "DataFrame" and cls.__module__.split(".")[0] == "pandas"


def filled_slabs(v: np.ndarray) -> np.ndarray | None:
    """Of a large array of 4 or more axes, which of its slabs (its last three axes: images) hold a nonzero byte:
    bool over the leading axes; None when every slab does, or the array is too small to care. An image matrix
    blends only the cells its path takes, and its other cells, zero, were most of what a run stored (arm_cross:
    212 MB written and hashed, 0.75 s on the run's critical path)."""
    if v.ndim < 4 or v.nbytes < SLAB_MIN_BYTES or v.size == 0:
        return None
    lead = v.shape[:-3]
    flat = np.ascontiguousarray(v).reshape(int(np.prod(lead)), -1)
    if flat.dtype.itemsize in (1, 2, 4, 8):  # by bytes: -0.0 is not zero, NaN is not
        flat = flat.view(f"u{flat.dtype.itemsize}")
    filled = flat.any(axis=1).reshape(lead)
    return None if filled.all() else filled


def content_hash(value: Any) -> str:
    """Deterministic sha256 (24 hex) of a stage output: arrays by bytes (all-zero slabs by their place only:
    filled_slabs), dataclasses field by field."""
    h = hashlib.sha256()

    def feed(v):
        if isinstance(v, np.ndarray) and (filled := filled_slabs(v)) is not None:
            h.update(str((v.dtype.str, v.shape, "slabs")).encode())
            h.update(np.packbits(filled).tobytes())
            slabs = np.asarray(v).reshape((-1, *v.shape[-3:]))
            for i in np.flatnonzero(filled):  # one slab at a time, not copied (a C-contiguous slab is a buffer)
                h.update(np.ascontiguousarray(slabs[i]))
        elif isinstance(v, np.ndarray):
            h.update(str((v.dtype.str, v.shape)).encode())
            h.update(np.ascontiguousarray(v).tobytes())
        elif dataclasses.is_dataclass(v):
            h.update(type(v).__name__.encode())
            for f in dataclasses.fields(v):
                h.update(f.name.encode())
                feed(getattr(v, f.name))
        elif _is_table(v):
            h.update(sys.modules["pandas"].util.hash_pandas_object(v, index=True).values.tobytes())
            h.update(",".join(map(str, v.columns)).encode())
        elif isinstance(v, (list, tuple)):
            h.update(f"[{len(v)}".encode())
            for x in v:
                feed(x)
        elif isinstance(v, dict):
            for k in sorted(v):
                h.update(str(k).encode())
                feed(v[k])
        else:
            h.update(json.dumps(v, default=str).encode())

    feed(value)
    return h.hexdigest()[:24]


def _save(value: Any, d: Path, prefix: str, arrays: dict, meta: dict) -> None:
    """Split a value into arrays (npz), images (EXR) and JSON scalars."""
    if dataclasses.is_dataclass(value):
        meta[prefix + "__type__"] = type(value).__name__
        for f in dataclasses.fields(value):
            _save(getattr(value, f.name), d, f"{prefix}{f.name}.", arrays, meta) if dataclasses.is_dataclass(getattr(value, f.name)) \
                else _save_field(f.name, getattr(value, f.name), d, prefix, arrays, meta)
    else:
        raise TypeError(f"cannot store {type(value)}")


def _save_field(name: str, v: Any, d: Path, prefix: str, arrays: dict, meta: dict) -> None:
    key = prefix + name
    if isinstance(v, np.ndarray) and name in IMAGE_FIELDS and v.ndim in (3, 4) and v.dtype == np.float32:
        stack = v if v.ndim == 4 else v[None]
        flat = stack.reshape((-1,) + stack.shape[-3:])
        for i, img in enumerate(flat):
            write_image(d / f"{key}.{i:04d}.exr", img, dtype="float")
        meta[key] = {"__images__": list(v.shape)}
    elif isinstance(v, np.ndarray) and (filled := filled_slabs(v)) is not None:
        arrays[key] = np.asarray(v)[filled]  # (N, ...) the slabs that hold something; the others are zero
        arrays[key + ".__filled__"] = filled
        meta[key] = {"__slabs__": list(v.shape)}
    elif isinstance(v, np.ndarray):
        arrays[key] = v
        meta[key] = {"__array__": True}
    elif isinstance(v, list) and v and all(isinstance(x, np.ndarray) for x in v):
        for i, x in enumerate(v):
            arrays[f"{key}.{i}"] = x
        meta[key] = {"__array_list__": len(v)}
    elif isinstance(v, list) and not v:
        meta[key] = {"__empty_list__": True}
    else:
        meta[key] = {"__json__": v}


def _load(d: Path, prefix: str, arrays, meta: dict) -> Any:
    cls = _TYPES[meta[prefix + "__type__"]]
    kwargs = {}
    for f in dataclasses.fields(cls):
        key = prefix + f.name
        if key + ".__type__" in meta:
            kwargs[f.name] = _load(d, key + ".", arrays, meta)
            continue
        if key not in meta and (f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING):
            continue  # written before the field existed: its default (the stage is stale anyway, its code changed)
        m = meta[key]
        if "__images__" in m:
            shape = tuple(m["__images__"])
            n = int(np.prod(shape[:-3])) if len(shape) == 4 else 1
            imgs = np.stack([read_image(d / f"{key}.{i:04d}.exr") for i in range(n)])
            kwargs[f.name] = imgs.reshape(shape).astype(np.float32)
        elif "__array__" in m:
            kwargs[f.name] = arrays[key]
        elif "__slabs__" in m:
            filled, slabs = arrays[key + ".__filled__"], arrays[key]
            full = np.zeros(tuple(m["__slabs__"]), slabs.dtype)
            full[filled] = slabs
            kwargs[f.name] = full
        elif "__array_list__" in m:
            kwargs[f.name] = [arrays[f"{key}.{i}"] for i in range(m["__array_list__"])]
        elif "__empty_list__" in m:
            kwargs[f.name] = []
        else:
            v = m["__json__"]
            kwargs[f.name] = tuple(v) if isinstance(v, list) and f.type.startswith("tuple") else v
    return cls(**kwargs)


def write_value(path: Path, value: Any, digest: str | None = None, provenance: dict | None = None) -> str:
    """Write a stage output atomically into directory `path`; returns its content hash (given or computed)."""
    tmp, digest = _write_beside(path, value, digest, provenance)
    try:
        _put_in_place(tmp, path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return digest


def _write_beside(path: Path, value: Any, digest: str | None, provenance: dict | None) -> tuple[Path, str]:
    """Write a stage output completely into a new temporary sibling of `path`; (that directory, content hash)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.parent / f".tmp-{path.name}-{uuid.uuid4().hex[:8]}"
    tmp.mkdir()
    try:
        digest = digest or content_hash(value)
        meta: dict = {"hash": digest}
        if _is_table(value):
            value.to_parquet(tmp / "table.parquet")
            value.to_csv(tmp / "table.csv", index=False)
            meta["__kind__"] = "table"
        else:
            arrays: dict = {}
            _save(value, tmp, "", arrays, meta)
            with open(tmp / "arrays.npz", "wb") as f:
                np.savez(f, **arrays)
            meta["__kind__"] = "dataclass"
        meta["__files__"] = {f.name: f.stat().st_size for f in sorted(tmp.iterdir())}
        if provenance is not None:
            meta["__provenance__"] = provenance
        _write_json(tmp / "meta.json", meta)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return tmp, digest


def _put_in_place(tmp: Path, path: Path) -> None:
    """Rename a complete output directory written by _write_beside to `path` (replacing what was there)."""
    old = path.parent / f".old-{path.name}-{uuid.uuid4().hex[:8]}"
    if path.exists():
        os.replace(path, old)
    os.replace(tmp, path)
    shutil.rmtree(old, ignore_errors=True)


def _write_json(path: Path, data: dict) -> None:
    """Write JSON and flush it to disk before it is renamed into place."""
    with open(path, "w") as f:
        json.dump(data, f, default=str)
        f.flush()
        os.fsync(f.fileno())


def read_value(path: Path) -> Any:
    """Read a stage output written by write_value."""
    meta = json.loads((path / "meta.json").read_text())
    if meta["__kind__"] == "table":
        import pandas as pd

        return pd.read_parquet(path / "table.parquet")
    return _load(path, "", read_npz(path / "arrays.npz"), meta)


def read_meta(path: Path) -> dict | None:
    """meta.json of the output at `path` if it is complete (every recorded file present at its size), else None."""
    try:
        meta = json.loads((path / "meta.json").read_text())
        if not isinstance(meta, dict) or not isinstance(meta.get("hash"), str):
            return None  # a meta.json edited or damaged into something else
        files = meta.get("__files__")
        if files is not None and (not isinstance(files, dict)
                                  or any((path / name).stat().st_size != size for name, size in files.items())):
            return None
        provenance = meta.get("__provenance__")
        return meta if provenance is None or isinstance(provenance, dict) else None
    except (OSError, ValueError, TypeError):
        return None


def stored_hash(path: Path) -> str | None:
    """Content hash of the complete output at `path`, or None if missing or damaged."""
    meta = read_meta(path)
    return meta["hash"] if meta else None


def stored_provenance(path: Path) -> tuple[str | None, dict | None]:
    """(content hash, recorded provenance) of the output at `path`; (None, None) if missing or damaged."""
    meta = read_meta(path)
    return (meta["hash"], meta.get("__provenance__")) if meta else (None, None)


def update_provenance(path: Path, provenance: dict) -> None:
    """Replace the provenance of an intact output (meta.json rewritten atomically; the data files stay)."""
    meta = json.loads((path / "meta.json").read_text())
    meta["__provenance__"] = provenance
    tmp = path / f".meta-{uuid.uuid4().hex[:8]}.json"
    _write_json(tmp, meta)
    os.replace(tmp, path / "meta.json")


# outputs written ahead of their `write` in this process: output directory -> (staged directory, hash, provenance)
_STAGED: dict[Path, tuple[Path, str, str]] = {}
_STAGED_LOCK = threading.Lock()


def _record_key(provenance: dict | None) -> str:
    return json.dumps(provenance, sort_keys=True, default=str)


class Store:
    """Stage outputs of every shot under `root`: <root>/<partition>/<stage name>/."""

    def __init__(self, root: str | Path):
        self.root = Path(root)

    def path(self, name: str, partition: str) -> Path:
        """Directory of stage `name` (e.g. 'key0/masks') for a shot partition."""
        return self.root / partition / name

    def read(self, name: str, partition: str) -> Any:
        return read_value(self.path(name, partition))

    def write(self, name: str, partition: str, value: Any, digest: str | None = None,
              provenance: dict | None = None) -> str:
        """Store an output; when `stage` already wrote this very output (same hash and provenance), only
        rename it into place."""
        path = self.path(name, partition)
        staged = self._take_staged(path)
        if staged is not None:
            tmp, staged_digest, record = staged
            if digest is not None and staged_digest == digest and record == _record_key(provenance):
                try:
                    _put_in_place(tmp, path)
                    return digest
                finally:
                    shutil.rmtree(tmp, ignore_errors=True)
            shutil.rmtree(tmp, ignore_errors=True)
        return write_value(path, value, digest, provenance)

    def stage(self, name: str, partition: str, value: Any, digest: str, provenance: dict | None = None) -> None:
        """Write an output ahead of its `write` (on the thread that computed it): complete beside its place,
        not read by anyone, until `write` renames it there; `discard` removes it."""
        path = self.path(name, partition)
        tmp, digest = _write_beside(path, value, digest, provenance)
        with _STAGED_LOCK:
            previous = _STAGED.pop(path, None)
            _STAGED[path] = (tmp, digest, _record_key(provenance))
        if previous is not None:
            shutil.rmtree(previous[0], ignore_errors=True)

    def discard(self, name: str, partition: str) -> None:
        """Remove an output staged and never written (its run failed)."""
        staged = self._take_staged(self.path(name, partition))
        if staged is not None:
            shutil.rmtree(staged[0], ignore_errors=True)

    @staticmethod
    def _take_staged(path: Path) -> tuple[Path, str, str] | None:
        with _STAGED_LOCK:
            return _STAGED.pop(path, None)

    def hash(self, name: str, partition: str) -> str | None:
        return stored_hash(self.path(name, partition))

    def provenance(self, name: str, partition: str) -> tuple[str | None, dict | None]:
        return stored_provenance(self.path(name, partition))

    def preview_path(self, name: str, partition: str) -> Path:
        """PNG preview of a stage, beside the outputs of its shot."""
        return self.root / partition / "previews" / (name.replace("/", "__") + ".png")
