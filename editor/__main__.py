"""`python -m editor SHOT_DIR [--port 8765] [--no-browser]`, which `inbetween edit` runs."""
from __future__ import annotations

import argparse
import sys

from ops.errors import ShotError

from .server import serve


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="inbetween edit", description="Annotate a shot in the browser and rerun it.")
    p.add_argument("shot_dir")
    p.add_argument("--port", type=int, default=8765, help="port on 127.0.0.1 (0: any free port)")
    p.add_argument("--no-browser", action="store_true", help="do not open the default browser")
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        return serve(args.shot_dir, args.port, not args.no_browser)
    except ShotError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 0


if __name__ == "__main__":
    sys.exit(main())
