"""The configuration of the resources stages use, as plain data: part of every stage's provenance. No Dagster.

A stage records the configuration of each resource it used (the RIFE model's weights, device and batch; the
inpainter's method and radius), so changing one makes exactly the stages that use that resource stale, as a
changed setting does. The CLI's runs configure the resources from the environment:

  INBETWEEN_DEVICE           rife.device        cpu | cuda
  INBETWEEN_RIFE_WEIGHTS     rife.weights_path  another RIFE HDv3 flownet.pkl
  INBETWEEN_RIFE_BATCH       rife.batch         image pairs per network call (an integer >= 1)
  INBETWEEN_RIFE_RUNTIME     rife.runtime       onnxruntime | torch (what runs the network on the CPU)
  INBETWEEN_INPAINTER        inpainter.method   see resources/inpainter.py
  INBETWEEN_INPAINT_RADIUS   inpainter.radius   pixels (an integer >= 1)

A run launched from the Dagster UI may configure them in its run config instead: what a stage records is the
configuration of the resource object it was given.
"""
from __future__ import annotations

import os
from collections.abc import Mapping

from ops.blending.rife_files import RUNTIMES
from ops.errors import ShotError

# resource key -> field -> (environment variable, type)
ENVIRONMENT: dict[str, dict[str, tuple[str, type]]] = {
    "rife": {"device": ("INBETWEEN_DEVICE", str), "weights_path": ("INBETWEEN_RIFE_WEIGHTS", str),
             "batch": ("INBETWEEN_RIFE_BATCH", int), "runtime": ("INBETWEEN_RIFE_RUNTIME", str)},
    "inpainter": {"method": ("INBETWEEN_INPAINTER", str), "radius": ("INBETWEEN_INPAINT_RADIUS", int)},
}

CHOICES: dict[tuple[str, str], tuple[str, ...]] = {("rife", "runtime"): RUNTIMES}  # closed sets


def resource_overrides(env: Mapping[str, str] | None = None) -> dict[str, dict]:
    """{resource key: {field: value}} set by the environment; ShotError naming the variable on a bad value."""
    env = os.environ if env is None else env
    out: dict[str, dict] = {}
    for key, fields in ENVIRONMENT.items():
        for field, (var, kind) in fields.items():
            text = env.get(var)
            if text is None or text == "":
                continue
            if kind is int:
                try:
                    value = int(text)
                except ValueError:
                    value = 0
                if value < 1:
                    raise ShotError("environment", var, f"{text!r} is not an integer >= 1",
                                    f"set {var} to a whole number, or unset it")
                out.setdefault(key, {})[field] = value
            else:
                choices = CHOICES.get((key, field))
                if choices and text not in choices:
                    raise ShotError("environment", var, f"{text!r} is not one of {', '.join(choices)}",
                                    f"set {var} to one of them, or unset it")
                out.setdefault(key, {})[field] = text
    return out


def resource_config(resource) -> dict:
    """{field: value} of a configurable resource object (its pydantic fields), JSON-able."""
    return {name: getattr(resource, name) for name in type(resource).model_fields}
