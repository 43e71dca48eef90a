"""Every endpoint's parameters are checked: a malformed one is a 400 with the one-line error naming the route and
the parameter, never a 500 (and never Starlette's bare 404 for a path that is there)."""
from __future__ import annotations

import json

import pytest

from .conftest import call

BAD = [  # (method, path, body, the parameter the error names)
    ("GET", "/api/matrix.png?thumb=abc", None, "thumb"),
    ("GET", "/api/matrix.png?thumb=9999", None, "thumb"),
    ("GET", "/api/matrix.png?seg=1", None, "seg"),
    ("GET", "/api/matrix?seg=x", None, "seg"),
    ("POST", "/api/motion", {"times": ["a"]}, "times"),
    ("POST", "/api/motion", {"times": 0.5}, "times"),
    ("POST", "/api/motion", {"shot": [1, 2]}, "shot"),
    ("POST", "/api/motion", b"{not json", "body"),
    ("POST", "/api/motion", [1], "body"),
    ("POST", "/api/repose", b"", "body"),
    ("POST", "/api/repose", {"k": "one", "joints": [[0, 0, 0]]}, "k"),
    ("POST", "/api/repose", {"k": 7, "joints": [[0, 0, 0]]}, "k"),
    ("POST", "/api/repose", {"k": 1, "t": "half", "joints": [[0, 0, 0]]}, "t"),
    ("POST", "/api/repose", {"k": 1, "t": 2.0, "joints": [[0, 0, 0]]}, "t"),
    ("POST", "/api/repose", {"k": 1}, "joints"),
    ("POST", "/api/repose", {"k": 1, "joints": [[0, 0]]}, "joints"),
    ("POST", "/api/repose", {"k": 1, "joints": [[0, 0, "z"]]}, "joints"),
    ("POST", "/api/repose", {"k": 1, "joints": [[0, 0, 0]], "scale": "big"}, "scale"),
    ("POST", "/api/repose", {"k": 1, "joints": [[0, 0, 0]], "settle": "yes"}, "settle"),
    ("POST", "/api/repose", {"k": 1, "joints": [[0, 0, 0]], "format": "gif"}, "format"),
    ("PUT", "/api/shot", b"{not json", "shot.json"),
    ("PUT", "/api/shot", [1, 2], "shot.json"),
    ("GET", "/api/keyframes/abc.png", None, "k"),
    ("GET", "/api/keyframes/5.png", None, "k"),
    ("GET", "/api/predicted/x", None, "k"),
    ("GET", "/api/predicted/1/skin.png", None, "layer"),
    ("GET", "/api/predicted/1/occlusion.png", None, "i"),
    ("GET", "/api/predicted/1/occlusion/z.png", None, "i"),
    ("GET", "/api/predicted/1/foreground/0.png", None, "i"),
    ("GET", "/api/refined/9", None, "k"),
    ("GET", "/api/proposals?key=x", None, "key"),
    ("GET", "/api/proposals?key=9", None, "key"),
    ("GET", "/api/proposals", None, "key"),
    ("GET", "/api/refined/1/skin/0.png", None, "layer"),
    ("GET", "/api/frames/x.png", None, "i"),
    ("GET", "/api/previews/no_such_stage.png", None, "stage"),
    ("GET", "/api/masks/../escape.png", None, "mask name"),
    ("PUT", "/api/masks/key0.png", b"x", "mask name"),
    ("POST", "/api/keys?name=a.png", b"x", "frame"),
    ("POST", "/api/keys?frame=-3&name=a.png", b"x", "frame"),
    ("POST", "/api/keys?frame=4000&name=a.png", b"x", "frame"),
    ("POST", "/api/keys?frame=4", b"x", "name"),
    ("POST", "/api/keys?frame=4&name=a.png", b"", "body"),
    ("DELETE", "/api/keys/x", None, "k"),
    ("DELETE", "/api/keys/2", None, "k"),
    ("POST", "/api/keys/1/move", b"{not json", "body"),
    ("POST", "/api/keys/1/move", {"frame": True}, "frame"),
    ("POST", "/api/keys/one/move", {"frame": 3}, "k"),
]


@pytest.mark.parametrize("method, path, body, field", BAD, ids=[f"{m} {p} {f}" for m, p, _, f in BAD])
def test_a_malformed_parameter_is_a_400_naming_it(serve, small_shot, method, path, body, field):
    s = serve(small_shot)
    raw = body if isinstance(body, bytes) or body is None else json.dumps(body).encode()
    status, headers, got = call(s.url + path, method, raw, {"Content-Type": "application/json"})
    assert status == 400, (status, got[:300])
    err = json.loads(got)
    assert err["field"] == field and "\n" not in err["error"] and "; fix: " in err["error"], err
    assert f": {field}: " in err["error"]


def test_an_unexpected_failure_is_still_one_json_line(serve, small_shot, monkeypatch):
    s = serve(small_shot)

    def broken():
        raise KeyError("x")

    monkeypatch.setattr(s.state.results, "frames_info", broken)
    status, _, got = call(s.url + "/api/frames")
    err = json.loads(got)
    assert status == 500 and "KeyError" in err["error"] and "\n" not in err["error"]
