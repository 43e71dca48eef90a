"""The classes of the resources stages declare, by key, and the objects a run of the CLI gets: each class
configured from the environment (assets/resource_config.py).

Kept apart from the Definitions (assets/definitions.py) so that a run can build the very objects the
Definitions bind as soon as Dagster is imported, before the Definitions and the instance are made (about a
second of the main thread, more under load): a stage that needs the inpainter or the network gets it then
(assets/run/execute.py).
"""
from __future__ import annotations

from typing import Any

from resources.inpainter import InpainterResource
from resources.rife import RifeResource

from .resource_config import resource_overrides

# the resources a stage may declare, by key (assets/compute.py names their modules, for the code records)
RESOURCE_TYPES: dict[str, type] = {"rife": RifeResource, "inpainter": InpainterResource}


def model_resources() -> dict[str, Any]:
    """{key: resource object} of every declarable resource, configured from the environment, as the
    Definitions bind them."""
    return {key: kind(**resource_overrides().get(key, {})) for key, kind in RESOURCE_TYPES.items()}
