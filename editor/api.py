"""The JSON API under /api (docs/editor.md, "The JSON API"): thin handlers over editor/state.py and the run machinery.

Every error is a JSON object {"error": "<one line>", "field": "<shot.json field or null>"}: the CLI's
ShotError message for bad input, so the page can show it next to the item the field names. A malformed
request parameter is a 400 naming the route and the parameter (editor/params.py), never a 500.
"""
from __future__ import annotations

import asyncio
import functools
import hashlib
import json
from pathlib import Path

import numpy as np
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import JSONResponse, Response, StreamingResponse
from starlette.routing import Route

from assets.graph import shot_graph
from assets.run import plan
from ops.errors import ShotError
from ops.preview import to_png_bytes
from ops.shotio.image_io import image_size, read_image, to_rgba
from ops.shotio.interpolate import resample_poses
from ops.shotio.load import (
    FORMAT_V2,
    IMAGE_SUFFIXES,
    MAX_FRAMES,
    MAX_JOINTS,
    MAX_KEYS,
    load_shot,
    parse_poses,
    parse_skeleton,
    read_shot_json,
)
from ops.skeleton.templates import TEMPLATES

from . import keys as key_edits
from . import params
from .jointcheck import check_key_joints, mask_inside
from .layers import refined_json
from .maskfiles import check_name, decode_mask, encode_mask
from .motion import v2_motion
from .repose import png_bytes
from .shotfile import keyframe_names, referenced_files, save, validate, write_atomic
from .stage_warnings import stage_warnings
from .state import EditorState

PNG = "image/png"
NO_STORE = {"Cache-Control": "no-store"}


def _ed(request: Request) -> EditorState:
    return request.app.state.editor


def _error(e: ShotError | str, status: int = 400) -> JSONResponse:
    if isinstance(e, ShotError):
        return JSONResponse({"error": str(e), "field": e.field}, status)
    return JSONResponse({"error": e, "field": None}, status)


def _png(data: bytes | None, what: str) -> Response:
    return Response(data, media_type=PNG, headers=NO_STORE) if data is not None else _error(f"no {what} yet", 404)


def handler(fn):
    """An API handler: bad input (a ShotError, here or in its blocking work) becomes a 400 with the one line."""

    @functools.wraps(fn)
    async def wrapped(request: Request) -> Response:
        try:
            return await fn(request)
        except ShotError as e:
            return _error(e)

    return wrapped


async def _call(fn, *args):
    """Run blocking work off the event loop (a ShotError propagates to `handler`)."""
    return await run_in_threadpool(fn, *args)


def _saved(ed: EditorState) -> dict:
    return read_shot_json(ed.shot_dir)[1]


def _n_keys(data: dict) -> int:
    """Keys of a shot.json object as the graph counts them: v1 two, v2 its keyframes (1..MAX_KEYS)."""
    if data.get("format") != FORMAT_V2:
        return 2
    return min(MAX_KEYS, max(1, len(keyframe_names(data))))


def _key(request: Request, ed: EditorState) -> int:
    """Path parameter k: a keyframe of the saved shot (the two of format v1)."""
    return params.path_int(request, "k", 0, _n_keys(_saved(ed)) - 1)


def _layer(request: Request) -> tuple[str, int | None]:
    """Path parameters layer ("foreground", or "occlusion" with its region index i)."""
    layer = params.choice(request, "layer", request.path_params["layer"], ("foreground", "occlusion"))
    if layer == "occlusion" and "i" not in request.path_params:
        raise ShotError(params.where(request), "i", "an occlusion layer needs its region index",
                        "ask for occlusion/{i}.png")
    if layer == "foreground" and "i" in request.path_params:
        raise ShotError(params.where(request), "i", "the foreground has no regions", "ask for foreground.png")
    return layer, params.path_int(request, "i", 0) if layer == "occlusion" else None


def _size(ed: EditorState) -> tuple[int, int]:
    """(H, W) of keyframe 0 of the saved shot (ShotError when it cannot be read)."""
    data = _saved(ed)
    names = keyframe_names(data)
    if not names:
        raise ShotError(ed.shot_dir / "shot.json", "keyframes", "names no image", 'write "keyframes": ["key0.png", "key1.png"]')
    return image_size(ed.shot_dir / names[0], "keyframes[0]")


# ---------------------------------------------------------------- the shot and its saving


@handler
async def info(request: Request) -> Response:
    ed = _ed(request)

    def work():
        try:
            size = list(_size(ed))
        except ShotError:
            size = None
        try:
            n_keys = _n_keys(_saved(ed))
        except ShotError:
            n_keys = 2
        graph = shot_graph(n_keys)
        return JSONResponse({"shot_dir": str(ed.shot_dir), "partition": ed.partition, "size": size,
                             "out_dir": str(ed.reruns.out_dir), "keys": n_keys, "stages": list(graph.stages),
                             "parents": {n: list(p) for n, p in graph.parents.items()}, "sources": list(graph.sources)})

    return await _call(work)


def _etag(ed: EditorState) -> str:
    """Version of shot.json on disk: a PUT carrying another one (If-Match) would overwrite someone else's edit."""
    return '"' + hashlib.sha256((ed.shot_dir / "shot.json").read_bytes()).hexdigest()[:20] + '"'


def _changed_on_disk(request: Request, ed: EditorState) -> bool:
    expected = request.headers.get("if-match")
    return expected is not None and expected != _etag(ed)


def _changed_error(ed: EditorState) -> JSONResponse:
    return _error(f"{ed.shot_dir / 'shot.json'}: shot.json: changed on disk since the editor loaded it; "
                  "fix: reload the page (saving would overwrite that change)", 409)


@handler
async def get_shot(request: Request) -> Response:
    ed = _ed(request)
    return await _call(lambda: JSONResponse(_saved(ed), headers={**NO_STORE, "ETag": _etag(ed)}))


@handler
async def check(request: Request) -> Response:
    """The loader's verdict on the saved shot: {"ok": true}, or {"ok": false, "error", "field"} (a shot the
    loader refuses still opens, to be fixed)."""
    ed = _ed(request)

    def work():
        try:
            load_shot(ed.shot_dir)
        except ShotError as e:
            return JSONResponse({"ok": False, "error": str(e), "field": e.field}, headers=NO_STORE)
        return JSONResponse({"ok": True, "error": None, "field": None}, headers=NO_STORE)

    return await _call(work)


@handler
async def put_shot(request: Request) -> Response:
    """Validate the whole shot.json object; write it (and the staged masks it names) and queue its rerun."""
    ed = _ed(request)
    try:
        data = json.loads(await request.body())
    except (ValueError, RecursionError) as e:
        return _error(ShotError(ed.shot_dir / "shot.json", "shot.json", f"the request body is not JSON ({e})",
                                "send the whole shot.json object"))

    def work():
        with ed.save_lock:
            if _changed_on_disk(request, ed):
                return _changed_error(ed)
            try:
                before = _saved(ed)
            except ShotError:
                before = None  # an unreadable shot.json is replaced: every joint counts as new

            def joints_on_drawing(shot, candidate, file):
                check_key_joints(shot, candidate, file, before, ed.foregrounds.of)

            staged = ed.staging.snapshot()
            validate(ed.shot_dir, data, staged, ed.scratch, joints_on_drawing)
            written = save(ed.shot_dir, data, staged)
            ed.staging.discard(written, only_if=staged)
            ed.reruns.request("save")  # from here on /api/status reports this save's rerun
            return JSONResponse({"ok": True}, headers={"ETag": _etag(ed)})

    return await _call(work)


@handler
async def run(request: Request) -> Response:
    """Rerun the saved shot without a change (the page's Run button)."""
    ed = _ed(request)

    def work():
        load_shot(ed.shot_dir)
        ed.reruns.request("run")
        return JSONResponse({"ok": True})

    return await _call(work)


async def status(request: Request) -> Response:
    return JSONResponse(_ed(request).reruns.snapshot()[1], headers=NO_STORE)


async def events(request: Request) -> Response:
    """Server-sent events: the status object each time it changes (a comment every 15 s keeps proxies open)."""
    ed = _ed(request)

    async def stream():
        last, quiet = -1, 0.0
        while not await request.is_disconnected():
            version, snap = ed.reruns.snapshot()
            if version != last:
                last, quiet = version, 0.0
                yield f"data: {json.dumps(snap)}\n\n"
            elif quiet > 15:
                quiet = 0.0
                yield ": keep-alive\n\n"
            await asyncio.sleep(0.2)
            quiet += 0.2

    return StreamingResponse(stream(), media_type="text/event-stream", headers=NO_STORE)


@handler
async def get_plan(request: Request) -> Response:
    """Status of every stage for the saved shot: fresh, or stale / missing with the causes."""
    ed = _ed(request)

    def work():
        p = plan(ed.shot_dir, ed.settings)
        return JSONResponse({"stages": {n: {"state": s.state, "causes": s.causes} for n, s in p.statuses.items()}},
                            headers=NO_STORE)

    return await _call(work)


@handler
async def get_warnings(request: Request) -> Response:
    """The stored stages' warnings, each with the subject it names and where (editor/stage_warnings.py)."""
    ed = _ed(request)
    return await _call(lambda: JSONResponse({"warnings": stage_warnings(ed.store, ed.partition)}, headers=NO_STORE))


async def templates(request: Request) -> Response:
    """The skeleton templates a skeleton can start from: {name: {"joints", "parents", "positions"}}, positions
    (u, v) in the unit box of the box the user drags (ops/skeleton/templates.py)."""
    return JSONResponse({name: t.to_json() for name, t in TEMPLATES.items()})


# ---------------------------------------------------------------- the timeline of keys (editor/keys.py)

MAX_UPLOAD_BYTES = 256 * 2**20  # a keyframe of MAX_SIDE px per side as 16-bit RGBA TIFF is about 200 MB


def _structural(request: Request, ed: EditorState, edit, new_files: dict[str, bytes] | None = None) -> Response:
    """Apply `edit(saved shot.json object, file) -> (object, extra answer fields)` to the saved shot, validate
    the result as the CLI would (with `new_files` in place), write the new files and shot.json, queue the rerun.
    Nothing is written when the edit or the validation refuses."""
    with ed.save_lock:
        if _changed_on_disk(request, ed):
            return _changed_error(ed)
        file, before = read_shot_json(ed.shot_dir)
        data, extra = edit(before, file)
        validate(ed.shot_dir, data, {}, ed.scratch, new_files=new_files)
        for rel, content in (new_files or {}).items():
            write_atomic(ed.shot_dir / rel, content)
        save(ed.shot_dir, data, {})
        ed.reruns.request("timeline")  # from here on /api/status reports this edit's rerun
        return JSONResponse({"ok": True, "keys": len(data["keyframes"]), "format": data["format"], **extra},
                            headers={"ETag": _etag(ed)})


@handler
async def add_key(request: Request) -> Response:
    """Query frame (the output frame) and name (the file's name), body the image file: a key there, the file
    copied into the shot folder under a free name. {"ok", "k" (the new key's index), "name", "keys"}."""
    ed = _ed(request)
    if "frame" not in request.query_params:
        raise ShotError(params.where(request), "frame", "is missing", "give the new key's output frame as ?frame=N")
    frame = params.query_int(request, "frame", 0, 0, MAX_FRAMES - 1)
    raw_name = request.query_params.get("name")
    if not raw_name:
        raise ShotError(params.where(request), "name", "is missing", "give the image file's name as ?name=FILE.png")
    declared = request.headers.get("content-length", "")
    if declared.isdecimal() and int(declared) > MAX_UPLOAD_BYTES:  # refused before it is read into memory
        raise ShotError(params.where(request), "body", f"is {declared} bytes, more than {MAX_UPLOAD_BYTES}",
                        "upload a smaller image file")
    body = await request.body()
    if not body:
        raise ShotError(params.where(request), "body", "is empty", "send the image file as the request body")
    if len(body) > MAX_UPLOAD_BYTES:
        raise ShotError(params.where(request), "body", f"is {len(body)} bytes, more than {MAX_UPLOAD_BYTES}",
                        "upload a smaller image file")

    def work():
        file, saved = read_shot_json(ed.shot_dir)
        taken = set(keyframe_names(saved)) | set(referenced_files(saved)) | {p.name for p in ed.shot_dir.iterdir()}
        name = key_edits.upload_name(raw_name, taken, IMAGE_SUFFIXES, file)
        motion = load_shot(ed.shot_dir).poses  # (F, J, 3): the new key's pose starts from the motion there

        def edit(data, file):
            out, k = key_edits.add_key(data, file, name, frame, motion)
            return out, {"k": k, "name": name}

        return _structural(request, ed, edit, {name: body})

    return await _call(work)


@handler
async def remove_key(request: Request) -> Response:
    """Remove key k (its image file stays in the folder); refuses the last key. {"ok", "keys", "dropped"}."""
    ed = _ed(request)

    def work():
        k = _key(request, ed)

        def edit(data, file):
            out, dropped = key_edits.remove_key(data, file, k)
            return out, {"dropped": dropped}

        return _structural(request, ed, edit)

    return await _call(work)


@handler
async def move_key(request: Request) -> Response:
    """Body {"frame": N}: key k at output frame N, its pose with it. {"ok", "k", "keys", "dropped"}."""
    ed = _ed(request)
    body = await params.json_body(request)
    frame = body.get("frame")
    if not isinstance(frame, int) or isinstance(frame, bool) or not 0 <= frame < MAX_FRAMES:
        raise ShotError(params.where(request), "frame", f"{json.dumps(frame)[:40]} is not a frame",
                        f"give frame as an integer from 0 to {MAX_FRAMES - 1}")

    def work():
        k = _key(request, ed)

        def edit(data, file):
            out, dropped = key_edits.move_key(data, file, k, frame)
            return out, {"k": k, "dropped": dropped}

        return _structural(request, ed, edit)

    return await _call(work)


# ---------------------------------------------------------------- images and masks


@handler
async def keyframe(request: Request) -> Response:
    ed = _ed(request)

    def work():
        k = _key(request, ed)
        names = keyframe_names(_saved(ed))
        if k >= len(names):
            raise ShotError(ed.shot_dir / "shot.json", "keyframes", f"names no image for keyframe {k}",
                            'write "keyframes": ["key0.png", "key1.png"]')
        img = read_image(ed.shot_dir / names[k], f"keyframes[{k}]")
        return Response(to_png_bytes(to_rgba(img)), media_type=PNG, headers=NO_STORE)

    return await _call(work)


@handler
async def get_mask(request: Request) -> Response:
    """A manual mask as 8-bit grey PNG (255 = inside): the staged upload, else the file the saved shot names."""
    ed = _ed(request)
    name = request.path_params["name"]

    def work():
        staged = ed.staging.get(name)
        if staged is not None:
            return Response(staged, media_type=PNG, headers=NO_STORE)
        data = _saved(ed)
        check_name(name, set(keyframe_names(data)))
        if name not in referenced_files(data):
            return _error(f"{name}: no staged upload and the saved shot.json names no such mask", 404)
        return Response(encode_mask(mask_inside(ed.shot_dir / name, "masks")), media_type=PNG, headers=NO_STORE)

    return await _call(work)


@handler
async def put_mask(request: Request) -> Response:
    """Stage a mask upload (any PNG; normalized to 8-bit 0/255); a later PUT /api/shot that names it writes it."""
    ed = _ed(request)
    name = request.path_params["name"]
    body = await request.body()

    def work():
        check_name(name, set(keyframe_names(_saved(ed))))
        png = encode_mask(decode_mask(body, _size(ed), name))
        ed.staging.put(name, png)
        return JSONResponse({"ok": True, "name": name})

    return await _call(work)


@handler
async def predicted(request: Request) -> Response:
    """{"regions", "source"} of keyframe k's predicted masks; the masks themselves are PNG sub-resources."""
    ed = _ed(request)

    def work():
        masks, source = ed.predictions.get(ed.shot_dir, _key(request, ed))
        return JSONResponse({"regions": len(masks.occlusion), "source": source, "warnings": masks.warnings})

    return await _call(work)


def _mask_layer(masks, layer: str, i: int | None) -> np.ndarray | None:
    if layer == "foreground":
        return masks.foreground
    return masks.occlusion[i] if i is not None and 0 <= i < len(masks.occlusion) else None


@handler
async def predicted_png(request: Request) -> Response:
    ed = _ed(request)

    def work():
        k, (layer, i) = _key(request, ed), _layer(request)
        masks, _ = ed.predictions.get(ed.shot_dir, k)
        m = _mask_layer(masks, layer, i)
        return _png(encode_mask(m) if m is not None else None, "such predicted region")

    return await _call(work)


@handler
async def refined(request: Request) -> Response:
    """Keyframe k's refined masks from the store: boundaries and snapped T-junctions (pixels), or 404."""
    ed = _ed(request)

    def work():
        name = f"key{_key(request, ed)}/refined_masks"
        version = ed.store.hash(name, ed.partition)
        if version is None:
            return _error("the refined masks have not been computed yet; save or run", 404)
        return JSONResponse({"version": version, **refined_json(ed.store.read(name, ed.partition))})

    return await _call(work)


@handler
async def refined_png(request: Request) -> Response:
    ed = _ed(request)

    def work():
        name, (layer, i) = f"key{_key(request, ed)}/refined_masks", _layer(request)
        if ed.store.hash(name, ed.partition) is None:
            return _png(None, "refined masks")
        m = _mask_layer(ed.store.read(name, ed.partition), layer, i)
        return _png(encode_mask(m) if m is not None else None, "such refined region")

    return await _call(work)


@handler
async def proposals(request: Request) -> Response:
    """Query key k: keyframe k's T-junction proposals (editor/proposals.py) {"key", "cached", "min_score",
    "click_wins_px", "hidden_by_clicks", "proposals": [{"x", "y", "score", "stem", "region"}, ...]}, best first,
    none within click_wins_px of a saved click."""
    ed = _ed(request)
    if "key" not in request.query_params:
        raise ShotError(params.where(request), "key", "is missing", "give the keyframe as ?key=K")

    def work():
        k = params.query_int(request, "key", 0, 0, _n_keys(_saved(ed)) - 1)
        return JSONResponse(ed.proposals.get(ed.shot_dir, k), headers=NO_STORE)

    return await _call(work)


# ---------------------------------------------------------------- motion and live re-pose


@handler
async def motion(request: Request) -> Response:
    """Poses at times: body {"shot": shot.json object (default: the saved one), "times": [t, ...] (default:
    the output times)} -> {"times", "poses" (T, J, 3), "given_times"}; interpolated per bone like the loader.
    A v2 shot's times are output frames (rounded to whole ones, the loader's motion there), and the answer
    adds its "key_frames"."""
    ed = _ed(request)
    body = await params.json_body(request, default={})
    shot = body.get("shot")
    if shot is not None and not isinstance(shot, dict):
        raise ShotError(params.where(request), "shot", "is not a shot.json object", "send the shot.json object, or leave shot out")
    times = body.get("times")
    if times is not None:
        times = params.numbers(request, "times", times, max_len=MAX_FRAMES)

    def work():
        data = shot or _saved(ed)
        file = ed.shot_dir / "shot.json"
        if data.get("format") == FORMAT_V2:
            knots, _, kf, poses = v2_motion(data, file)
            at = np.arange(len(poses)) if times is None else np.clip(np.rint(times), 0, len(poses) - 1).astype(int)
            return JSONResponse({"times": at.tolist(), "poses": np.round(poses[at], 4).tolist(),
                                 "given_times": knots.tolist(), "key_frames": list(kf)})
        skeleton = parse_skeleton(data, file)
        given_t, given = parse_poses(data, file, skeleton)
        frames = data.get("frames")
        at = times
        if at is None:
            at = np.linspace(0.0, 1.0, frames) if isinstance(frames, int) and 2 <= frames <= MAX_FRAMES else given_t
        at = np.clip(np.asarray(at, float), 0.0, 1.0)
        poses = resample_poses(given_t, given, at, skeleton.parents)
        return JSONResponse({"times": at.tolist(), "poses": np.round(poses, 4).tolist(),
                             "given_times": given_t.tolist()})

    return await _call(work)


@handler
async def repose(request: Request) -> Response:
    """Body {"k": key, "seg": segment (default 0), "t": the segment's time in [0, 1], "joints": [[x, y, z], ...],
    "scale": display px per pixel (<= 1), "settle": bool (false while a drag goes on: a bounded solve), "format":
    "png" | "rgba"} -> keyframe k's textured template of segment seg (k is one of its two keys) deformed into
    that pose, over white: a PNG, or raw 8-bit RGBA rows (X-Width, X-Height headers; the page's choice, no
    encoding). Timings in X-Solve-Ms, X-Render-Ms, X-Iterations, X-Cpu-Ms."""
    ed = _ed(request)
    body = await params.json_body(request)
    n_keys = await run_in_threadpool(lambda: _n_keys(_saved(ed)))
    seg = body.get("seg", 0)
    n_seg = max(1, n_keys - 1)
    if not isinstance(seg, int) or isinstance(seg, bool) or not 0 <= seg < n_seg:
        raise ShotError(params.where(request), "seg", f"{json.dumps(seg)[:40]} is not a segment",
                        f"give seg from 0 to {n_seg - 1}")
    keys = (0,) if n_keys == 1 else (seg, seg + 1)
    k = body.get("k", keys[0])
    if not isinstance(k, int) or isinstance(k, bool) or k not in keys:
        raise ShotError(params.where(request), "k", f"{json.dumps(k)[:40]} is not a keyframe of segment {seg}",
                        f"give k as {' or '.join(map(str, keys))}")
    t = params.number(request, "t", body.get("t", 0.5), 0.0, 1.0)
    if "joints" not in body:
        raise ShotError(params.where(request), "joints", "is missing", "send one [x, y, z] per joint")
    pose = np.asarray(params.points(request, "joints", body["joints"], 3, MAX_JOINTS), float)
    scale = float(np.clip(params.number(request, "scale", body.get("scale", 1.0)), 0.05, 1.0))
    settle = params.boolean(request, "settle", body.get("settle", True))
    fmt = params.choice(request, "format", body.get("format", "png"), ("png", "rgba"))

    def work():
        reposer = ed.reposers.get(k, seg)
        if reposer is None:
            return _error(f"seg{seg}/key{k}/textured_template has not been computed yet; run the shot first", 409)
        if len(pose) != reposer.textured.template.handle_weights.shape[1]:
            return _error("the skeleton changed since the template was built; save and rerun first", 409)
        res = reposer.update(pose, t, scale, settle=settle)
        h, w = res.image.shape[:2]
        headers = {**NO_STORE, "X-Solve-Ms": f"{res.solve_ms:.1f}", "X-Render-Ms": f"{res.render_ms:.1f}",
                   "X-Iterations": str(res.iterations), "X-Cpu-Ms": f"{res.cpu_ms:.1f}", "X-Width": str(w),
                   "X-Height": str(h)}
        if fmt == "rgba":
            return Response(res.image.tobytes(), media_type="application/octet-stream", headers=headers)
        return Response(png_bytes(res.image), media_type=PNG, headers=headers)

    return await _call(work)


# ---------------------------------------------------------------- results


async def frames(request: Request) -> Response:
    got = await run_in_threadpool(_ed(request).results.frames_info)
    return JSONResponse(got, headers=NO_STORE) if got else _error("no frames yet; save or run", 404)


@handler
async def frame_png(request: Request) -> Response:
    i = params.path_int(request, "i", 0)
    return _png(await run_in_threadpool(_ed(request).results.frame_png, i), f"frame {i}")


def _segment(request: Request, ed: EditorState) -> int:
    """Query parameter seg: a segment (k, k + 1) of the saved shot (default 0)."""
    return params.query_int(request, "seg", 0, 0, max(1, _n_keys(_saved(ed)) - 1) - 1)


@handler
async def matrix(request: Request) -> Response:
    ed = _ed(request)
    got = await run_in_threadpool(lambda: ed.results.paths_info(_segment(request, ed)))
    return JSONResponse(got, headers=NO_STORE) if got else _error("no image matrix yet; save or run", 404)


@handler
async def matrix_png(request: Request) -> Response:
    ed = _ed(request)
    thumb = params.query_int(request, "thumb", 64, 16, 256)
    return _png(await run_in_threadpool(lambda: ed.results.matrix_png(thumb, _segment(request, ed))), "image matrix")


def _graph(ed: EditorState):
    """The stage graph of the saved shot (two keys while shot.json cannot be read)."""
    try:
        return shot_graph(_n_keys(_saved(ed)))
    except ShotError:
        return shot_graph(2)


async def previews(request: Request) -> Response:
    ed = _ed(request)
    stages = (await run_in_threadpool(_graph, ed)).stages
    return JSONResponse([{"stage": n, "available": ed.store.preview_path(n, ed.partition).is_file()} for n in stages],
                        headers=NO_STORE)


@handler
async def preview_png(request: Request) -> Response:
    ed = _ed(request)
    stage = params.choice(request, "stage", request.path_params["stage"].removesuffix(".png"),
                          tuple((await run_in_threadpool(_graph, ed)).stages))
    path: Path = ed.store.preview_path(stage, ed.partition)
    return _png(path.read_bytes() if path.is_file() else None, f"preview of {stage}")


async def internal_error(request: Request, exc: Exception) -> Response:
    """Any other failure: still one JSON line for the page (the traceback goes to the editor's terminal)."""
    return _error(f"{params.where(request)}: the editor failed ({type(exc).__name__}: {' '.join(str(exc).split())[:200]}); "
                  "fix: see the editor's terminal for the trace, and report it", 500)


ROUTES = [
    Route("/api/info", info),
    Route("/api/shot", get_shot, methods=["GET"]),
    Route("/api/shot", put_shot, methods=["PUT"]),
    Route("/api/check", check),
    Route("/api/run", run, methods=["POST"]),
    Route("/api/status", status),
    Route("/api/events", events),
    Route("/api/plan", get_plan),
    Route("/api/warnings", get_warnings),
    Route("/api/templates", templates),
    Route("/api/keys", add_key, methods=["POST"]),
    Route("/api/keys/{k}", remove_key, methods=["DELETE"]),
    Route("/api/keys/{k}/move", move_key, methods=["POST"]),
    Route("/api/keyframes/{k}.png", keyframe),
    Route("/api/masks/{name:path}", get_mask, methods=["GET"]),
    Route("/api/masks/{name:path}", put_mask, methods=["PUT"]),
    Route("/api/predicted/{k}", predicted),
    Route("/api/predicted/{k}/{layer}.png", predicted_png),
    Route("/api/predicted/{k}/{layer}/{i}.png", predicted_png),
    Route("/api/refined/{k}", refined),
    Route("/api/refined/{k}/{layer}.png", refined_png),
    Route("/api/refined/{k}/{layer}/{i}.png", refined_png),
    Route("/api/proposals", proposals),
    Route("/api/motion", motion, methods=["POST"]),
    Route("/api/repose", repose, methods=["POST"]),
    Route("/api/frames", frames),
    Route("/api/frames/{i}.png", frame_png),
    Route("/api/matrix", matrix),
    Route("/api/matrix.png", matrix_png),
    Route("/api/previews", previews),
    Route("/api/previews/{stage:path}", preview_png),
]
