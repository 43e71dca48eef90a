"""Where stage outputs live: a partition-aware IO manager with atomic writes.

Layout: <root>/<partition>/<asset/key/path>/ holding
  meta.json    dataclass type, scalar fields, content hash (written last)
  arrays.npz   every numpy array field (lists of arrays as name.0, name.1, ...)
  <field>.exr  image fields (float, lossless) through OpenImageIO
  table.parquet + table.csv  for pandas DataFrames
A stage is written into a temporary sibling directory and renamed into place,
so a killed run never leaves a half-written output that a rerun would trust.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import uuid
from pathlib import Path
from typing import Any

import dagster as dg
import numpy as np
import pandas as pd
from pydantic import Field

from ops import types as T
from ops.image_io import read_image, write_image

# fields stored as images (H, W, C) float32 via OpenImageIO; stacks (N, H, W, C) as one file per image
IMAGE_FIELDS = {"texture", "back_texture", "images", "frames"}
_TYPES = {cls.__name__: cls for cls in vars(T).values() if dataclasses.is_dataclass(cls) and isinstance(cls, type)}


def content_hash(value: Any) -> str:
    """Deterministic sha256 (24 hex) of a stage output: arrays by bytes, dataclasses field by field."""
    h = hashlib.sha256()

    def feed(v):
        if isinstance(v, np.ndarray):
            h.update(str((v.dtype.str, v.shape)).encode())
            h.update(np.ascontiguousarray(v).tobytes())
        elif dataclasses.is_dataclass(v):
            h.update(type(v).__name__.encode())
            for f in dataclasses.fields(v):
                h.update(f.name.encode())
                feed(getattr(v, f.name))
        elif isinstance(v, pd.DataFrame):
            h.update(pd.util.hash_pandas_object(v, index=True).values.tobytes())
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
        m = meta[key]
        if "__images__" in m:
            shape = tuple(m["__images__"])
            n = int(np.prod(shape[:-3])) if len(shape) == 4 else 1
            imgs = np.stack([read_image(d / f"{key}.{i:04d}.exr") for i in range(n)])
            kwargs[f.name] = imgs.reshape(shape).astype(np.float32)
        elif "__array__" in m:
            kwargs[f.name] = arrays[key]
        elif "__array_list__" in m:
            kwargs[f.name] = [arrays[f"{key}.{i}"] for i in range(m["__array_list__"])]
        elif "__empty_list__" in m:
            kwargs[f.name] = []
        else:
            v = m["__json__"]
            kwargs[f.name] = tuple(v) if isinstance(v, list) and f.type.startswith("tuple") else v
    return cls(**kwargs)


def write_value(path: Path, value: Any, digest: str | None = None) -> str:
    """Write a stage output atomically into directory `path`; returns its content hash (given or computed)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.parent / f".tmp-{path.name}-{uuid.uuid4().hex[:8]}"
    tmp.mkdir()
    try:
        digest = digest or content_hash(value)
        meta: dict = {"hash": digest}
        if isinstance(value, pd.DataFrame):
            value.to_parquet(tmp / "table.parquet")
            value.to_csv(tmp / "table.csv", index=False)
            meta["__kind__"] = "table"
        else:
            arrays: dict = {}
            _save(value, tmp, "", arrays, meta)
            with open(tmp / "arrays.npz", "wb") as f:
                np.savez(f, **arrays)
            meta["__kind__"] = "dataclass"
        (tmp / "meta.json").write_text(json.dumps(meta, default=str))
        old = path.parent / f".old-{path.name}-{uuid.uuid4().hex[:8]}"
        if path.exists():
            os.replace(path, old)
        os.replace(tmp, path)
        shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return digest


def read_value(path: Path) -> Any:
    """Read a stage output written by write_value."""
    meta = json.loads((path / "meta.json").read_text())
    if meta["__kind__"] == "table":
        return pd.read_parquet(path / "table.parquet")
    with np.load(path / "arrays.npz", allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    return _load(path, "", arrays, meta)


def stored_hash(path: Path) -> str | None:
    """Content hash of the complete output at `path`, or None if missing."""
    try:
        return json.loads((path / "meta.json").read_text())["hash"]
    except (OSError, ValueError, KeyError):
        return None


class StageStore(dg.ConfigurableIOManager):
    """Partition-aware IO manager: one directory per (partition, asset) under `root`."""

    root: str = Field(description="Directory holding every stage output, one sub-folder per shot partition.")

    def path(self, asset_key: dg.AssetKey, partition: str) -> Path:
        return Path(self.root) / partition / Path(*asset_key.path)

    def handle_output(self, context: dg.OutputContext, obj: Any) -> None:
        path = self.path(context.asset_key, context.partition_key)
        digest = content_hash(obj)
        if stored_hash(path) == digest:  # unchanged output: keep the file, skip the write
            return
        write_value(path, obj, digest)

    def load_input(self, context: dg.InputContext) -> Any:
        return self.read(context.asset_key, context.partition_key)

    def read(self, asset_key: dg.AssetKey, partition: str) -> Any:
        return read_value(self.path(asset_key, partition))

    def exists(self, asset_key: dg.AssetKey, partition: str) -> bool:
        return stored_hash(self.path(asset_key, partition)) is not None
