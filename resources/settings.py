"""The method's parameters as a Dagster resource, derived field by field from ops.settings.Settings.

The resource class is built from the dataclass so the two can never disagree
(a default or a description changed in one place changes both).
"""
from __future__ import annotations

from dataclasses import MISSING, fields

import dagster as dg
from pydantic import Field

from ops.settings import Settings


def _values(self) -> Settings:
    """The plain frozen dataclass with this resource's values."""
    return Settings(**{f.name: getattr(self, f.name) for f in fields(Settings)})


def _class_body() -> dict:
    """One pydantic Field per Settings field (same type, default and description), plus `values()`."""
    body: dict = {"__annotations__": {}, "__module__": __name__, "values": _values,
                  "__doc__": "Parameters of the method (ops.settings.Settings); each value a stage reads is recorded "
                             "in its provenance."}
    for f in fields(Settings):
        assert f.default is not MISSING, f"Settings.{f.name} needs a default"
        body["__annotations__"][f.name] = type(f.default)
        body[f.name] = Field(f.default, description=f.metadata["doc"])
    return body


PipelineSettings = type("PipelineSettings", (dg.ConfigurableResource,), _class_body())
