"""The `inbetween` command line (docs/cli.md; the shot format: docs/shot-format.md). It parses, calls, prints.

The work is done by assets/run/, the run machinery every front end shares.
Bad input prints one line and exits 2; a stage that fails prints one line
(shot, stage, cause, and where the full log is) and exits 1; so does any other
error (its trace goes to a log under INBETWEEN_HOME/logs/, never to the terminal).

Quiet by default: stderr holds one progress line per shot (assets/console.py)
and the error lines, nothing else. Dagster's event log goes to
INBETWEEN_HOME/logs/*.log, Python warnings to INBETWEEN_HOME/logs/warnings.log;
--verbose shows both live. Results (where the frames are, the batch table) go
to stdout.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import traceback
from pathlib import Path

STARTED = time.perf_counter()  # the command's start, before its heavy imports: the wall clock every figure counts from

from ops.errors import ShotError  # noqa: E402
from ops.settings import OCCLUSION_PREDICTORS, Settings  # noqa: E402
from ops.shotio.frames import DEFAULT_EXPORTS, EXPORTS  # noqa: E402

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report it


def _settings(args) -> Settings:
    return Settings(blend=getattr(args, "blend", "optimal"), template_mode=getattr(args, "template", "optimized"),
                    occlusion=getattr(args, "occlusion", Settings().occlusion),
                    register_lanes=getattr(args, "lanes", "registered") == "registered",
                    implied_cuts=getattr(args, "cuts", "implied") == "implied")


def _exports(text: str) -> tuple[str, ...]:
    """--export's value: 'all' or a comma-separated subset of EXPORTS."""
    if text == "all":
        return EXPORTS
    got = tuple(dict.fromkeys(t.strip() for t in text.split(",") if t.strip()))
    bad = [t for t in got if t not in EXPORTS]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown export {bad[0]!r}: use some of {','.join(EXPORTS)} or all")
    return got


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="inbetween", description="Skeleton-driven inbetweening of bitmap drawings.")
    sub = parser.add_subparsers(dest="command", required=True)

    def occlusion_flag(p):
        p.add_argument("--occlusion", choices=OCCLUSION_PREDICTORS, default=Settings().occlusion,
                       help="predict occlusion masks from the skeleton alone, the skeleton's shaped by the drawing "
                            "(hybrid), those split into one region per overlapping bone pair (pairs), or read them "
                            "off the drawing (a small network, the skeleton as a guide)")

    def lanes_flag(p):
        p.add_argument("--lanes", choices=["registered", "skeleton"], default="registered",
                       help="registered: each lane is registered onto the other key's drawing and faded in over the "
                            "segment (docs/lanes.md); skeleton: the lanes follow the skeleton alone")

    def cuts_flag(p):
        p.add_argument("--cuts", choices=["implied", "clicked"], default="implied",
                       help="implied: an occlusion region without T-junction clicks also tries the cut its outline "
                            "implies (docs/method.md); clicked: the paper's switching rule alone")

    def output_flags(p):
        p.add_argument("--export", type=_exports, default=DEFAULT_EXPORTS, metavar="LIST",
                       help=f"what OUT gets besides frames/*.png, comma-separated: {','.join(EXPORTS)} or all "
                            f"(default {','.join(DEFAULT_EXPORTS)}): previews over white, an Open Cel Animation "
                            "folder with the keys marked, a ProRes 4444 video with alpha")
        p.add_argument("--fps", type=float, default=12.0, help="frames per second of the videos and the OCA document")

    def method_flags(p):
        p.add_argument("--blend", choices=["optimal", "diagonal"], default="optimal")
        p.add_argument("--template", choices=["optimized", "single-layer"], default="optimized")
        occlusion_flag(p)
        lanes_flag(p)
        cuts_flag(p)
        p.add_argument("--verbose", action="store_true", help="show Dagster's event log live")
        p.add_argument("--debug", action="store_true", help="print the full trace when a stage fails")

    p = sub.add_parser("run", help="in-between one shot")
    p.add_argument("shot_dir")
    p.add_argument("--out", required=True)
    output_flags(p)
    method_flags(p)
    wa = sub.add_parser("watch", help="run a shot, then rerun it each time its files are saved (Ctrl-C stops)")
    wa.add_argument("shot_dir")
    wa.add_argument("--out", required=True)
    output_flags(wa)
    method_flags(wa)
    b = sub.add_parser("batch", help="every shot under a root, in parallel")
    b.add_argument("shots_root")
    b.add_argument("--out", required=True)
    b.add_argument("--workers", type=int, default=2, choices=range(1, 65), metavar="{1..64}")
    b.add_argument("--executor", choices=["in_process", "celery"], default="in_process",
                   help="celery: every step on `inbetween worker` processes (docs/production.md)")
    output_flags(b)
    method_flags(b)
    s = sub.add_parser("status", help="which stages of a shot the next run executes, and why")
    s.add_argument("shot_dir")
    s.add_argument("--json", action="store_true", help="print the statuses as JSON")
    s.add_argument("--blend", choices=["optimal", "diagonal"], default="optimal")
    s.add_argument("--template", choices=["optimized", "single-layer"], default="optimized")
    occlusion_flag(s)
    lanes_flag(s)
    cuts_flag(s)
    m = sub.add_parser("masks", help="write a shot's masks in the form masks.foreground / masks.occlusion accept")
    m.add_argument("shot_dir")
    m.add_argument("--out", required=True)
    m.add_argument("--predicted", action="store_true",
                   help="the occlusion masks as predicted, before the T-junctions refine them")
    occlusion_flag(m)
    j = sub.add_parser("junctions", help="propose T-junctions for the keys that have no clicks (and accept them)")
    j.add_argument("shot_dir")
    j.add_argument("--write", action="store_true", help="add the proposals scoring at least --min-score to shot.json")
    j.add_argument("--min-score", type=float, default=0.5, help="least score written by --write (0 .. 1)")
    occlusion_flag(j)
    e = sub.add_parser("eval", help="evaluate shots that carry ground truth")
    e.add_argument("shots_root")
    e.add_argument("--out", default=None)
    occlusion_flag(e)
    lanes_flag(e)
    cuts_flag(e)
    u = sub.add_parser("ui", help="open the Dagster UI on this project's instance")
    u.add_argument("--port", type=int, default=3000, help="port on 127.0.0.1")
    ed = sub.add_parser("edit", help="annotate a shot in the browser; saving reruns it incrementally")
    ed.add_argument("shot_dir")
    ed.add_argument("--port", type=int, default=8765, help="port on 127.0.0.1 (0: any free port)")
    ed.add_argument("--no-browser", action="store_true", help="do not open the default browser")
    n = sub.add_parser("new", help="start a shot from drawings, or from an AnimatedDrawings character")
    n.add_argument("shot_dir")
    n.add_argument("images", nargs="*", help="one drawing per keyframe")
    n.add_argument("--skeleton", default="humanoid", help="humanoid, quadruped or a skeleton JSON file")
    n.add_argument("--key-frames", default=None, help="output frame of each keyframe, e.g. 0,8,20 (default 0,8,16,...)")
    n.add_argument("--animated-drawings", default=None, metavar="CHAR_CFG.yaml",
                   help="AnimatedDrawings' character folder's char_cfg.yaml (texture.png, mask.png beside it)")
    motion_flags = lambda q: (q.add_argument("--bvh", default=None, help="a BVH motion clip"),  # noqa: E731
                              q.add_argument("--retarget", default=None, help="AnimatedDrawings' retarget config"),
                              q.add_argument("--bvh-frames", default=None, metavar="START:END:STEP",
                                             help="a Python slice of the clip's frames (default: all, at most 30 fps)"))
    motion_flags(n)
    n.add_argument("--keep-canvas", action="store_true",
                   help="with --bvh: keep the texture's size even where the motion leaves it (default: grow the canvas)")
    mo = sub.add_parser("motion", help="drive a shot's skeleton by a BVH clip or by points tracked in a video")
    mo.add_argument("shot_dir")
    motion_flags(mo)
    mo.add_argument("--video", default=None, help="a video whose points drive the skeleton")
    mo.add_argument("--points", default=None, help='POINTS.json: {"joint name": [x, y], ...} in the first frame')
    w = sub.add_parser("worker", help="a farm worker: runs the steps of `batch --executor celery` (docs/production.md)")
    w.add_argument("--queue", action="append", choices=["cpu", "gpu"],
                   help="queue to serve, repeatable (default cpu); gpu: the RIFE steps, with INBETWEEN_DEVICE=cuda")
    w.add_argument("--concurrency", type=int, default=1, help="steps at once (1: in this process; N: N children)")
    w.add_argument("--threads", type=int, default=None, help="torch threads per step (default: cores / concurrency)")
    w.add_argument("--broker", default=None, help="Celery broker URL (default: INBETWEEN_BROKER, else local Redis)")
    w.add_argument("--visibility-timeout", type=float, default=None,
                   help="seconds before an unacknowledged step goes to another worker (longer than any stage)")
    w.add_argument("--name", default=None, help="worker name (default: QUEUES-PID@HOST)")
    w.add_argument("--loglevel", default="INFO")
    return parser


def shot_stages(partition: str) -> tuple[str, ...]:
    """The stages of a registered shot's graph, from its shot.json's keyframe count (no validation: a shot
    that fails to load shows a two-key line until it fails)."""
    from ops.shotio.load import MAX_KEYS
    from resources.registry import lookup

    from .graph import shot_graph
    from .home import home

    try:
        shot_dir = lookup(home() / "shots.json", partition)
        n = len(json.loads((shot_dir / "shot.json").read_text())["keyframes"])
    except (OSError, ValueError, TypeError, KeyError):
        n = 2
    return shot_graph(min(max(n, 1), MAX_KEYS)).stages


def _board(args):
    from .console import Board

    # with --verbose Dagster's log scrolls on stderr: lines redrawn in place would fight it
    return Board(shot_stages, live=False if getattr(args, "verbose", False) else None)


def _run(args) -> int:
    from . import processes

    processes.warm_up()  # the workers' fork server imports the ops while this process imports and plans
    from .run import run_shot

    board = _board(args)
    name = Path(args.shot_dir).resolve().name

    def waiting():
        board.say(f"waiting: another run of {args.shot_dir} holds its lock; it starts when that one ends")

    with board.follow():
        try:
            report = run_shot(args.shot_dir, args.out, _settings(args), on_wait=waiting, verbose=args.verbose,
                              exports=args.export, fps=args.fps, started=args.started)
        except Exception as e:
            for partition in list(board.lines):
                board.finish(partition, name, None, "bad input" if isinstance(e, ShotError) else "failed")
            raise
    board.finish(report["partition"], name, report, "ok")
    ran = [n for n, s in report["stages"].items() if not s["cached"]]
    print(f"{report['frames']} frames -> {Path(args.out) / 'frames'}  "
          f"({len(ran)} stages executed, {report['seconds_total']:.1f} s)")
    return 0


def _watch(args) -> int:
    from .run.watch import watch

    # the reruns take `inbetween run`'s flags as given here: everything after SHOT_DIR and --out OUT
    options = [f"--export={','.join(args.export)}", f"--fps={args.fps}", f"--blend={args.blend}",
               f"--template={args.template}", f"--occlusion={args.occlusion}", f"--lanes={args.lanes}",
               f"--cuts={args.cuts}", *(["--debug"] if args.debug else []), *(["--verbose"] if args.verbose else [])]
    return watch(args.shot_dir, args.out, options, lambda line: print(line, flush=True))


def _farm_ready(args) -> bool:
    """For --executor celery: the farm's packages are there (else one line, False); warn when no worker answers."""
    from .farm.settings import missing_extra

    why = missing_extra()
    if why:
        print(f"error: {why}", file=sys.stderr)
        return False
    if args.command == "batch":
        from .farm.worker import answering

        if not answering():
            print("warning: no `inbetween worker` answered on the broker (INBETWEEN_BROKER) within 2 s: none runs, "
                  "or all are busy with a step; the steps wait in their queues", file=sys.stderr, flush=True)
    return True


def _batch(args) -> int:
    from .console import table
    from .run import batch, register

    board = _board(args)
    root = Path(args.shots_root)
    if not root.is_dir():
        raise ShotError(root, "SHOTS_ROOT", "is not a directory", "give the folder whose sub-folders are shots")
    partitions = {}  # shot name -> partition
    for d in sorted(root.iterdir()):
        if (d / "shot.json").is_file():
            partitions[d.name] = register(d)
            board.line(partitions[d.name], d.name)
    rows: dict[str, dict] = {}

    def done(name: str, r: dict | None, error) -> None:
        status = "ok" if r is not None else "bad input" if getattr(error, "bad_input", False) else "failed"
        board.finish(partitions.get(name, name), name, r, status)
        rows[name] = {"shot": name, "seconds": "-", "status": status}
        if r is not None:
            stages = r["stages"].values()
            rows[name].update(frames=r["frames"], seconds=r["seconds_total"],
                              cached=f"{sum(s['cached'] for s in stages)}/{len(stages)}",
                              warnings=sum(s.get("warnings", 0) for s in stages))

    if args.executor == "celery" and not _farm_ready(args):
        return EXIT_BAD_INPUT
    with board.follow():
        reports, errors = batch(root, args.out, args.workers, _settings(args), verbose=args.verbose, on_done=done,
                                executor=args.executor, exports=args.export, fps=args.fps)
    print(table([rows[n] for n in sorted(rows)]))
    for err in errors:
        _say(f"error: {err}")
    print(f"{len(reports)} shots done, {len(errors)} failed, {time.perf_counter() - args.started:.1f} s")
    if any(not getattr(e, "bad_input", True) for e in errors):
        return EXIT_FAILED
    return EXIT_BAD_INPUT if errors else 0


def _status(args) -> int:
    from .run import status

    p = status(args.shot_dir, _settings(args))
    if args.json:
        print(json.dumps({"shot": p.shot.root, "partition": p.partition,
                          "stages": {n: {"state": s.state, "causes": s.causes} for n, s in p.statuses.items()}},
                         indent=2))
    else:
        shot = p.shot
        for title, group in _status_groups(shot, p.statuses):
            print(title)
            for name, st in group:
                print(f"  {name:30s} {st.state:8s} {'; '.join(st.causes)}")
    return 0


def _status_groups(shot, statuses: dict) -> list[tuple[str, list]]:
    """The statuses under one heading per key (its lane), per segment (its sides and blending) and the shot."""
    groups: dict[str, list] = {}
    for name, st in statuses.items():
        head = name.split("/")[0]
        if head.startswith("key"):
            title = f"key {head[3:]} ({shot.keyframes[int(head[3:])].rsplit('/', 1)[-1]}, frame "\
                    f"{shot.key_frames[int(head[3:])]})"
        elif head.startswith("seg"):
            keys = shot.segment_keys(int(head[3:]))
            frames = shot.segment_frames(int(head[3:]))
            title = (f"segment {head[3:]} (keys {' -> '.join(map(str, keys))}, frames {frames[0]}-{frames[-1]})"
                     if len(keys) > 1 else f"the drawing along its motion (frames {frames[0]}-{frames[-1]})")
        else:
            title = "shot"
        groups.setdefault(title, []).append((name, st))
    return list(groups.items())


def _masks(args) -> int:
    from .run import export_masks

    for path in export_masks(args.shot_dir, args.out, _settings(args), predicted=args.predicted):
        print(path)
    return 0


def _junctions(args) -> int:
    from .run.junctions import accept_junctions, propose_junctions

    proposals = propose_junctions(args.shot_dir, _settings(args))
    if not proposals:
        print("every key has T-junction clicks: nothing to propose (a click always wins)")
    for k, props in proposals.items():
        print(f"key {k}: {len(props.points)} proposed")
        for (x, y), score in zip(props.points, props.scores):
            print(f"  ({x:7.1f}, {y:7.1f})  score {score:.2f}")
    if args.write and proposals:
        n = accept_junctions(args.shot_dir, proposals, args.min_score)
        print(f"wrote {n} T-junction(s) scoring >= {args.min_score} into shot.json (the old one: shot.json.bak)")
        if n:  # measured on held-out shots: -2.8 to +0.5 dB (docs/inpainting-and-proposals.md)
            print("they count as clicks now: after the next run, look at each key's refined_masks preview before "
                  "keeping them (a wrong one moves or grows an occlusion region)")
    elif proposals:
        print(f"next: inbetween edit {args.shot_dir} (accept them one by one), or rerun with --write")
    return 0


def _eval(args) -> int:
    from .evaluation_cli import evaluate_root

    return evaluate_root(args.shots_root, args.out, _settings(args))


def _ui(args) -> int:
    from .home import ensure_home

    ensure_home()
    root = Path(__file__).resolve().parent.parent
    # this interpreter's own Dagster, whatever PATH says (`.venv/bin/inbetween ui` without the venv activated)
    argv = [sys.executable, "-m", "dagster", "dev", "-h", "127.0.0.1", "-p", str(args.port),
            "-w", str(root / "workspace.yaml")]
    os.execv(sys.executable, argv)
    return 0


def _edit(args) -> int:
    # the editor is the layer above assets (nothing imports it): it runs as its own program, as `ui` runs dagster
    argv = [sys.executable, "-m", "editor", args.shot_dir, "--port", str(args.port)]
    os.execv(sys.executable, argv + (["--no-browser"] if args.no_browser else []))
    return 0


def _worker(args) -> int:
    if not _farm_ready(args):
        return EXIT_BAD_INPUT
    from .farm.settings import DEFAULT_VISIBILITY_TIMEOUT
    from .farm.worker import start_worker

    start_worker(tuple(args.queue or ["cpu"]), args.concurrency, args.threads, args.broker,
                 args.visibility_timeout or DEFAULT_VISIBILITY_TIMEOUT, args.name, args.loglevel)
    return 0


def _new(args) -> int:
    from . import starting

    if args.animated_drawings:
        if args.images:
            raise ShotError(args.images[0], "IMAGE", "--animated-drawings brings its own drawing (texture.png)",
                            "give either images or --animated-drawings")
        starting.new_from_animated_drawings(args.shot_dir, args.animated_drawings, args.bvh, args.retarget,
                                            args.bvh_frames, keep_canvas=args.keep_canvas)
    else:
        if args.keep_canvas:
            raise ShotError(args.shot_dir, "--keep-canvas", "only a clip grows the canvas (--animated-drawings "
                            "--bvh); drawings keep their own", "leave --keep-canvas out")
        if args.bvh or args.retarget or args.bvh_frames:
            raise ShotError(args.shot_dir, "--bvh", "a clip drives a shot that exists",
                            "run `inbetween new` first, then `inbetween motion SHOT_DIR --bvh ... --retarget ...`")
        starting.new_from_images(args.shot_dir, args.images, args.skeleton, args.key_frames)
    return 0


def _motion(args) -> int:
    from . import starting

    if bool(args.bvh) == bool(args.video):
        raise ShotError(args.shot_dir, "--bvh/--video", "give exactly one motion source",
                        "give --bvh CLIP.bvh --retarget RETARGET.yaml, or --video CLIP.mp4 --points POINTS.json")
    if args.bvh:
        starting.motion_from_bvh(args.shot_dir, args.bvh, args.retarget, args.bvh_frames)
    else:
        if not args.points:
            raise ShotError(args.video, "--points", "a video needs the points to track",
                            'give --points POINTS.json: {"joint name": [x, y], ...} in the first frame')
        starting.motion_from_video(args.shot_dir, args.video, args.points)
    return 0


COMMANDS = {"run": _run, "watch": _watch, "batch": _batch, "status": _status, "masks": _masks, "junctions": _junctions, "eval": _eval,
            "ui": _ui, "edit": _edit, "worker": _worker, "new": _new, "motion": _motion}


def _crash_log(trace: str) -> Path | None:
    """Write an unexpected error's trace under INBETWEEN_HOME/logs/; its path, or None if that fails too."""
    from .home import home

    try:
        path = home() / "logs" / f"{time.strftime('%Y%m%d-%H%M%S')}-error-{os.getpid()}.log"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(trace)
        return path
    except OSError:
        return None


def _say(text: str) -> None:
    """A line for the user on stderr, never into an image reader's capture of fd 2 on a thread still running."""
    from ops.shotio.image_io import say_on_stderr  # OpenImageIO: only on this path, and a run has loaded it

    say_on_stderr(text)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def main(argv: list[str] | None = None) -> int:
    """The `inbetween` command; argv None: this process's own command line, which ends when main returns."""
    # this process's own command counts from the process's start; a call from Python (a test) from the call
    code = _main(argv, STARTED if argv is None else time.perf_counter())
    if argv is None:
        from .run.leave import leave  # without finalizing the interpreter (0.5 s a command)

        leave(code)
    return code


def _main(argv: list[str] | None, started: float) -> int:
    args = _parser().parse_args(argv)
    args.started = started
    from .run import HomeDamaged, RunInterrupted, StageFailed, warnings_to_log

    if not getattr(args, "verbose", False):
        warnings_to_log()
    try:
        return COMMANDS[args.command](args)
    except ShotError as e:
        _say(f"error: {_one_line(e)}")
        return EXIT_BAD_INPUT
    except StageFailed as e:
        if getattr(args, "debug", False) and e.trace:
            _say(e.trace)
        where = f" (full log: {e.log})" if e.log else ""
        _say(f"error: {_one_line(e)}{where}")
        return EXIT_INTERRUPTED if isinstance(e, RunInterrupted) else EXIT_FAILED
    except HomeDamaged as e:
        _say(f"error: {_one_line(e)}")
        return EXIT_FAILED
    except KeyboardInterrupt:
        _say("error: interrupted; stages already stored are kept, a rerun continues from them")
        return EXIT_INTERRUPTED
    except Exception as e:  # anything else: one line here, the trace in a log
        trace = traceback.format_exc()
        if getattr(args, "debug", False):
            _say(trace.rstrip("\n"))
        log = _crash_log(trace)
        where = f" (full trace: {log})" if log else ""
        fix = ("free disk space, then rerun" if isinstance(e, OSError) and e.errno == 28
               else "rerun with --debug for the full trace")
        _say(f"error: {args.command}: {_one_line(f'{type(e).__name__}: {e}')[:300]}; fix: {fix}{where}")
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())
