"""Only this machine's browser may talk to the editor.

The server listens on 127.0.0.1, and that alone does not stop DNS rebinding: a web page on an attacker's
domain that resolves to 127.0.0.1 reaches the port with its own Host header. So every request must name
the loopback address or localhost *with the editor's port* in its Host header, and a request that
changes something (any method but GET/HEAD) coming from a page must come from the editor's own origin.
"""
from __future__ import annotations

import json

LOOPBACK_NAMES = ("127.0.0.1", "localhost")
SAFE_METHODS = ("GET", "HEAD")
# the page needs nothing from elsewhere: no CDN, no inline script
CSP = ("default-src 'self'; img-src 'self' blob: data:; style-src 'self'; script-src 'self'; "
       "connect-src 'self'; frame-ancestors 'none'")


class LocalOnly:
    """ASGI middleware: 403 for a foreign Host header or a foreign Origin on a state-changing request."""

    def __init__(self, app, port: int):
        self.app, self.port = app, port
        self.hosts = {f"{name}:{port}" for name in LOOPBACK_NAMES}
        self.origins = {f"http://{h}" for h in self.hosts}

    async def __call__(self, scope, receive, send):
        if scope["type"] == "http":
            headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
            host, origin = headers.get("host", "").lower(), headers.get("origin")
            problem = None
            if host not in self.hosts:
                problem = f"host {host!r} refused: open the editor at http://127.0.0.1:{self.port}/"
            elif scope["method"] not in SAFE_METHODS and origin is not None and origin.lower() not in self.origins:
                problem = f"origin {origin!r} refused"
            if problem:
                body = json.dumps({"error": problem, "field": None}).encode()
                await send({"type": "http.response.start", "status": 403,
                            "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]})
                await send({"type": "http.response.body", "body": body})
                return

            async def send_with_headers(message):
                if message["type"] == "http.response.start":
                    message["headers"] = [*message.get("headers", []), (b"content-security-policy", CSP.encode()),
                                          (b"x-content-type-options", b"nosniff")]
                await send(message)

            await self.app(scope, receive, send_with_headers)
            return
        await self.app(scope, receive, send)
