"""Request parameters of the JSON API, checked: a malformed one is a ShotError (400) naming the route, the
parameter and the fix, never a 500 from deep inside a handler."""
from __future__ import annotations

import json
import math

from starlette.requests import Request

from ops.errors import ShotError


def where(request: Request) -> str:
    """The route as errors name it, e.g. 'GET /api/matrix.png'."""
    return f"{request.method} {request.url.path}"


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


async def json_body(request: Request, default: dict | None = None) -> dict:
    """The body as a JSON object; `default` for an empty body (None: a body is required)."""
    raw = await request.body()
    if not raw.strip() and default is not None:
        return dict(default)
    try:
        data = json.loads(raw)
    except (ValueError, RecursionError) as e:
        raise ShotError(where(request), "body", f"is not JSON ({' '.join(str(e).split())[:80]})",
                        "send a JSON object") from None
    if not isinstance(data, dict):
        raise ShotError(where(request), "body", f"is a JSON {type(data).__name__}, not an object", "send a JSON object")
    return data


def query_int(request: Request, name: str, default: int, lo: int, hi: int) -> int:
    """Integer query parameter `name` in [lo, hi] (absent: default)."""
    raw = request.query_params.get(name)
    if raw is None:
        return default
    try:
        value = int(raw)
    except ValueError:
        raise ShotError(where(request), name, f"{raw[:40]!r} is not an integer",
                        f"give {name} as an integer from {lo} to {hi}") from None
    if not lo <= value <= hi:
        raise ShotError(where(request), name, f"{value} is outside {lo}..{hi}", f"give {name} from {lo} to {hi}")
    return value


def path_int(request: Request, name: str, lo: int, hi: int | None = None) -> int:
    """Integer path parameter `name` (the route captures it as text) in [lo, hi]."""
    raw = str(request.path_params[name])
    span = f"from {lo} to {hi}" if hi is not None else f"of at least {lo}"
    if not raw.isdecimal():
        raise ShotError(where(request), name, f"{raw[:40]!r} is not an integer", f"give {name} as an integer {span}")
    value = int(raw)
    if value < lo or (hi is not None and value > hi):
        raise ShotError(where(request), name, f"{value} does not exist", f"give {name} {span}")
    return value


def choice(request: Request, name: str, value, allowed: tuple[str, ...]) -> str:
    """`value` (of parameter `name`) when it is one of `allowed`."""
    if value not in allowed:
        raise ShotError(where(request), name, f"{str(value)[:40]!r} is not one of {', '.join(allowed)}",
                        f"give {name} as one of {', '.join(allowed)}")
    return value


def number(request: Request, name: str, value, lo: float | None = None, hi: float | None = None) -> float:
    """A finite JSON number in [lo, hi] (bounds optional)."""
    if not _is_number(value):
        raise ShotError(where(request), name, f"{json.dumps(value)[:40]} is not a finite number",
                        f"give {name} as a number")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ShotError(where(request), name, f"{value} is outside {lo}..{hi}", f"give {name} from {lo} to {hi}")
    return float(value)


def numbers(request: Request, name: str, value, max_len: int = 10_000) -> list[float]:
    """A JSON list of at most max_len finite numbers."""
    if not (isinstance(value, list) and len(value) <= max_len and all(_is_number(v) for v in value)):
        raise ShotError(where(request), name, f"must be a list of at most {max_len} finite numbers",
                        f"send {name} as [number, ...]")
    return [float(v) for v in value]


def points(request: Request, name: str, value, dims: int, max_len: int = 10_000) -> list[list[float]]:
    """A JSON list of at most max_len points of `dims` finite numbers each ([x, y] or [x, y, z])."""
    form = "[" + ", ".join("xyz"[:dims]) + "]"
    if not (isinstance(value, list) and 0 < len(value) <= max_len and all(
            isinstance(v, list) and len(v) == dims and all(_is_number(c) for c in v) for v in value)):
        raise ShotError(where(request), name, f"must be a list of {form} (finite numbers)",
                        f"send one {form} per joint")
    return [[float(c) for c in v] for v in value]


def boolean(request: Request, name: str, value) -> bool:
    if not isinstance(value, bool):
        raise ShotError(where(request), name, f"{json.dumps(value)[:40]} is not true or false", f"give {name} as true or false")
    return value
