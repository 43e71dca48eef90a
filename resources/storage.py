"""The stage store as a Dagster IO manager: partition-aware, atomic, provenance kept with each output.

The stage factory (assets/stage.py) hands the output's content hash and its
provenance over in the Output's metadata, so the value is hashed once and the
record is written with the data. A stage whose inputs were unchanged yields
no value (None): its stored output already is the value, and nothing is
rewritten.
"""
from __future__ import annotations

import json
from typing import Any

import dagster as dg
from pydantic import Field

from .store import Store

DIGEST_KEY = "inbetween/data_version"
PROVENANCE_KEY = "inbetween/provenance"


def _meta_text(context: dg.OutputContext, key: str) -> str | None:
    entry = (context.output_metadata or {}).get(key)
    return None if entry is None else getattr(entry, "value", entry)


class StageStore(dg.ConfigurableIOManager):
    """Partition-aware IO manager: one directory per (partition, asset) under `root` (resources/store.py)."""

    root: str = Field(description="Directory holding every stage output, one sub-folder per shot partition.")

    @property
    def files(self) -> Store:
        return Store(self.root)

    def handle_output(self, context: dg.OutputContext, obj: Any) -> None:
        if obj is None:  # unchanged inputs: the stored output is this value
            return
        name = "/".join(context.asset_key.path)
        provenance = _meta_text(context, PROVENANCE_KEY)
        self.files.write(name, context.partition_key, obj, _meta_text(context, DIGEST_KEY),
                         json.loads(provenance) if provenance else None)

    def load_input(self, context: dg.InputContext) -> Any:
        return self.files.read("/".join(context.asset_key.path), context.partition_key)
