"""The annotation editor: a local web app to fix a shot's annotations and watch its incremental rerun.

`inbetween edit SHOT_DIR` serves it on 127.0.0.1 (editor/server.py). The Python side is a thin Starlette
app over the same run machinery as the CLI (assets/run/); the page is plain ES modules and canvas
(editor/static/), with no build step. Nothing in assets/, resources/ or ops/ imports this package.
"""

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)
