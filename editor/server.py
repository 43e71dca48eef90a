"""`inbetween edit SHOT_DIR`: the Starlette app of the editor, served by uvicorn on 127.0.0.1 only."""
from __future__ import annotations

import contextlib
import socket
import sys
import threading
import webbrowser
from pathlib import Path

import uvicorn
from starlette.applications import Starlette
from starlette.responses import FileResponse
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from ops.errors import ShotError

from .api import ROUTES, internal_error
from .hosts import LocalOnly
from .state import EditorState

STATIC = Path(__file__).resolve().parent / "static"
HOST = "127.0.0.1"


class _Static(StaticFiles):
    """The page's files, revalidated on every load so an edited module is never stale in the browser."""

    async def get_response(self, path, scope):
        response = await super().get_response(path, scope)
        response.headers["Cache-Control"] = "no-cache"
        return response


async def _index(request):
    return FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})


def build_app(state: EditorState, port: int) -> LocalOnly:
    """The ASGI app: /api routes, the page at / and its modules under /static, behind the Host/Origin check."""

    @contextlib.asynccontextmanager
    async def lifespan(app):
        state.start()
        yield
        state.stop()

    app = Starlette(routes=[Route("/", _index), *ROUTES, Mount("/static", _Static(directory=STATIC))],
                    lifespan=lifespan, exception_handlers={Exception: internal_error})
    app.state.editor = state
    return LocalOnly(app, port)


def bind(port: int) -> socket.socket:
    """A listening socket on 127.0.0.1:port (port 0: any free port)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((HOST, port))
    sock.listen(128)
    return sock


def serve(shot_dir: str | Path, port: int = 8765, open_browser: bool = True) -> int:
    """Serve the editor of one shot until interrupted; prints its URL first. ShotError for an unreadable shot.json."""
    try:
        sock = bind(port)
    except OSError as e:
        raise ShotError("--port", "port", f"cannot listen on {HOST}:{port} ({e.strerror})",
                        "pick another port with --port") from None
    port = sock.getsockname()[1]
    url = f"http://{HOST}:{port}/"
    state = EditorState(shot_dir, url=url)
    config = uvicorn.Config(build_app(state, port), log_level="warning", timeout_graceful_shutdown=2, lifespan="on")
    server = uvicorn.Server(config)
    print(f"editor of {state.shot_dir} at {url}  (Ctrl-C stops it)", flush=True)
    if open_browser:
        threading.Timer(0.5, webbrowser.open, args=(url,)).start()
    server.run(sockets=[sock])
    _, st = state.reruns.snapshot()
    if st["state"] == "running":
        print("a rerun is still running; it finishes in the background, and `inbetween edit` follows it again",
              file=sys.stderr)
    return 0
