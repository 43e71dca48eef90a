"""End-to-end numbers of `inbetween` as a user runs it (a new process per command), in one report:

1. per sample shot: cold run (fresh INBETWEEN_HOME), warm rerun (nothing changed: must not start Dagster or
   import torch), rerun after moving key1's first T-junction by 1 px, the cold run of a copy of the shot in that
   home (a user's every new shot but the first: the Dagster instance exists), and RIFE-direct (a new process that loads
   the network from scratch and interpolates the two keyframes to every output time, as
   ops/evaluation/baselines.py rife_direct does); each run's time divided by RIFE-direct's on the same shot in
   the same run (machines of this kind differ up to 2.7x per core: the ratios compare, the seconds do not);
   wall and CPU seconds, and the Dagster
   overhead of the cold run: its wall time minus the stages' compute seconds (`ovh`, issue 11's measure; the
   two keyframe lanes compute at once, so their seconds overlap and this understates it), and its wall time
   minus the longest chain of stage seconds through the graph (`ovh-cp`: what no ordering of the stages on
   any number of cores could hide);
2. the per-stage split of every cold run (seconds from report.json);
3. scaling over resolution (arm_cross resized to 256, 384, 512, 1024 px, 9 frames) and over frame count
   (arm_cross at 384 px with only its key poses, `frames` = 5, 9, 17, 33): cold wall, rife_matrix, peak RSS;
4. `batch` over the sample shots: wall time and peak RSS (largest process, and the whole process tree);
5. adding 5 T-junctions to a shot (`--add-junctions`, default arm_cross, curled_tail, hand_on_hip): a cold run
   of the shot as it is and
   one with 5 more clicks on its occlusion boundaries (each in the middle of the longest stretch of boundary
   without one), per stage wall seconds before and after and their ratio, and in the same runs each stage's own
   CPU seconds (report.json's cpu_seconds: its thread's, its worker calls' and its pool's) and their ratio; then
   the stages the clicks rerun, each
   computed again alone in this process from the parents those runs stored (CPU seconds: no other lane on the
   cores, so the ratio is the stage's own).

    python benchmarks/bench_pipeline.py [--shots data_samples] [--only arm_cross ...] [--no-scaling] [--no-batch]
                                        [--add-junctions SHOT ... | --no-add-junctions] [--rounds N]

The machine is shared and its wall times are noisy: CPU seconds are printed beside them, and the load average
before and after. Targets (issue 11, measured on a machine ~2.5x faster than the 2-core one here): unchanged
rerun <= 1.5 s, Dagster overhead of a cold run <= 2 s, peak RSS of batch <= 1.5 GB.
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

ORIGINAL = ("arm_cross", "legs_cross", "manual_masks", "no_occlusion", "tail", "two_poses")
# runs the CLI; an atexit handler notes whether the process imported torch or Dagster (the CLI leaves with
# os._exit once done, after running the atexit handlers: code after the command would never run)
_CLI = ("import atexit, json, os, runpy, sys\n"
        "sys.argv = ['inbetween', *json.loads(sys.argv[1])]\n"
        "atexit.register(lambda: json.dump({'torch': 'torch' in sys.modules, 'dagster': 'dagster' in sys.modules},"
        " open(os.environ['BENCH_MODULES'], 'w')))\n"
        "runpy.run_module('assets.cli', run_name='__main__')\n")


def _tree_rss(pid: int) -> tuple[int, int]:
    """(sum, max) resident set size in bytes over a process and all its descendants."""
    children: dict[int, list[int]] = {}
    rss: dict[int, int] = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            pages = int((d / "statm").read_text().split()[1])
        except (OSError, ValueError, IndexError):
            continue
        children.setdefault(ppid, []).append(int(d.name))
        rss[int(d.name)] = pages * os.sysconf("SC_PAGE_SIZE")
    todo, seen = [pid], []
    while todo:
        p = todo.pop()
        seen.append(p)
        todo.extend(children.get(p, []))
    sizes = [rss.get(p, 0) for p in seen]
    return sum(sizes), max(sizes, default=0)


# RIFE alone, as a user would run it: a new process, the network loaded from scratch, the keyframes bisected
# to every output time (ops.evaluation.baselines.rife_direct), the frames written as PNG
# (runtime: 'torch', or 'onnxruntime' with the export already in the cache, as a user's second run finds it: then,
# as in the pipeline, without importing torch where the code can)
_RIFE_DIRECT = ("import inspect, json, sys\n"
                "from pathlib import Path\n"
                "from ops.evaluation.baselines import rife_direct\n"
                "from ops.shotio.image_io import read_image, to_rgba, write_image\n"
                "from ops.shotio.load import load_shot\n"
                "shot_dir, out, runtime, cache = json.loads(sys.argv[1])\n"
                "shot = load_shot(shot_dir)\n"
                "key0, key1 = (to_rgba(read_image(p)) for p in shot.keyframes)\n"
                "try:\n"
                "    from ops.blending.rife_onnx import open_export  # code from before: torch always\n"
                "except ImportError:\n"
                "    open_export = None\n"
                "try:  # nothing else runs in this process: ONNX Runtime's threads may spin, its fastest\n"
                "    from ops.blending.rife_onnx import set_spinning\n"
                "    set_spinning(True)\n"
                "except ImportError:\n"
                "    pass\n"
                "rife = open_export(None, cache) if open_export and runtime == 'onnxruntime' and cache else None\n"
                "if rife is None:\n"
                "    from ops.blending.rife import load_rife\n"
                "    has = 'runtime' in inspect.signature(load_rife).parameters  # older code: torch only\n"
                "    rife = load_rife(runtime=runtime, cache_dir=cache) if has else load_rife()\n"
                "frames = rife_direct(key0, key1, shot.times, rife)\n"
                "Path(out).mkdir(parents=True, exist_ok=True)\n"
                "for i, f in enumerate(frames):\n"
                "    write_image(Path(out) / f'{i:04d}.png', f)\n")


def cli(args: list[str], home: Path) -> dict:
    """Run `inbetween ARGS` as a new process; wall and CPU seconds, peak RSS (tree sum and largest process),
    and whether it imported torch and Dagster."""
    return process(_CLI, args, home)


def rife_direct(shot: Path, out: Path, home: Path, runtime: str = "torch") -> dict:
    """RIFE-direct on a shot as a new process (see _RIFE_DIRECT) with the network run by `runtime`: wall and CPU
    seconds, peak RSS. The ONNX export is read from the user's cache (resources/rife.py), as the pipeline does."""
    native = _native_simd()
    try:
        from resources.rife import default_cache_dir
    except ImportError:  # code from before the ONNX runtime: torch only
        return process(_RIFE_DIRECT, [str(shot), str(out), runtime, ""], home, native)
    return process(_RIFE_DIRECT, [str(shot), str(out), runtime, str(default_cache_dir())], home, native)


def _native_simd() -> dict[str, str | None]:
    """Environment changes that give RIFE-direct the CPU's own SIMD kernels (None: unset): the baseline is RIFE
    at its fastest on this machine, where our runs hold the libraries at AVX2 (ops/simd.py; PyTorch's RIFE takes
    about 1.2x the CPU there)."""
    try:
        from ops.simd import set_by_pin
    except ImportError:  # code from before the pin
        return {}
    return {"INBETWEEN_SIMD": "native", **dict.fromkeys(set_by_pin())}


def process(code: str, args: list[str], home: Path, env_changes: dict[str, str | None] | None = None) -> dict:
    """Run `python -c code json(args)` as a new process with its own INBETWEEN_HOME (and env_changes: None
    unsets); wall and CPU seconds, peak RSS (tree sum and largest process), and whether it imported torch and
    Dagster (for the CLI)."""
    home.mkdir(parents=True, exist_ok=True)
    modules = home.parent / f".modules-{os.getpid()}.json"
    env = {**os.environ, "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster"),
           "BENCH_MODULES": str(modules), "PYTHONPATH": str(ROOT)}
    for name, value in (env_changes or {}).items():
        if value is None:
            env.pop(name, None)
        else:
            env[name] = value
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", code, json.dumps(args)], env=env, cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    peak = [0, 0]
    done = threading.Event()

    def sample():
        while not done.wait(0.2):
            total, largest = _tree_rss(proc.pid)
            peak[0], peak[1] = max(peak[0], total), max(peak[1], largest)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    done.set()
    err = proc.stderr.read().decode(errors="replace")
    flags = json.loads(modules.read_text()) if modules.exists() else {}
    modules.unlink(missing_ok=True)
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{' '.join(args)} failed:\n{err[-2000:]}")
    peak_largest = max(peak[1], usage.ru_maxrss * 1024)
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "rss_sum": max(peak[0], peak_largest),
            "rss_max": peak_largest, "torch": flags.get("torch"), "dagster": flags.get("dagster")}


def load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def move_key1_junction(shot: Path) -> bool:
    """Move key1's first T-junction 1 px right (the editor's typical edit); False if key1 has none."""
    data = json.loads((shot / "shot.json").read_text())
    if not data["t_junctions"][1]:
        return False
    x, y = data["t_junctions"][1][0]
    data["t_junctions"][1][0] = [x + 1.0, y]
    (shot / "shot.json").write_text(json.dumps(data, indent=1))
    return True


def run_sample(src: Path, tmp: Path, rounds: int = 1) -> dict:
    """Cold, warm and after-edit runs of a copy of one shot, and RIFE-direct; their numbers and the cold run's report.

    With rounds > 1 the cold run, RIFE-direct (torch, ONNX Runtime) and the edit are repeated in turn, each round
    in a fresh INBETWEEN_HOME, so that each ratio divides runs made seconds apart; the median round (by cold/Ro)
    is the one reported, and every round's ratios are kept ("rounds")."""
    runs = []
    for i in range(rounds):
        shot = shutil.copytree(src, tmp / f"shots-{i}" / src.name)
        home, out = tmp / f"home-{src.name}-{i}", tmp / f"out-{src.name}-{i}"
        cold = cli(["run", str(shot), "--out", str(out)], home)
        report = json.loads((out / "report.json").read_text())
        warm = cli(["run", str(shot), "--out", str(tmp / f"out2-{src.name}-{i}")], home)
        rife = rife_direct(shot, tmp / f"rife-{src.name}-{i}", tmp / f"home-rife-{src.name}")
        rife_ort = rife_direct(shot, tmp / f"rife-ort-{src.name}-{i}", tmp / f"home-rife-{src.name}", "onnxruntime")
        edit = cli(["run", str(shot), "--out", str(out)], home) if move_key1_junction(shot) else None
        edited = json.loads((out / "report.json").read_text()) if edit else None
        # a new shot in a home that has run one already: every shot's cold run but the first of an install
        # (the first also creates the Dagster instance's SQLite tables)
        again = shutil.copytree(src, tmp / f"shots-{i}-again" / f"{src.name}-again")
        used = cli(["run", str(again), "--out", str(tmp / f"out-again-{src.name}-{i}")], home)
        runs.append({"cold": cold, "warm": warm, "edit": edit, "rife": rife, "rife_ort": rife_ort, "report": report,
                     "edited": edited, "used": used})
    ranked = sorted(runs, key=lambda r: r["cold"]["wall"] / r["rife_ort"]["wall"])
    median = dict(ranked[len(ranked) // 2])
    median["rounds"] = [{"cold/R": r["cold"]["wall"] / r["rife"]["wall"], "cold/Ro": r["cold"]["wall"] / r["rife_ort"]["wall"],
                         "used/R": r["used"]["wall"] / r["rife"]["wall"],
                         "used/Ro": r["used"]["wall"] / r["rife_ort"]["wall"],
                         "edit/R": r["edit"]["wall"] / r["rife"]["wall"] if r["edit"] else float("nan"),
                         "edit/Ro": r["edit"]["wall"] / r["rife_ort"]["wall"] if r["edit"] else float("nan")}
                        for r in runs]
    return median


def critical_path(stages: dict[str, dict]) -> float:
    """Seconds of the longest chain of stages through the graph (each after all of its parents)."""
    from assets.graph import shot_graph
    STAGES, PARENTS = shot_graph(2).stages, shot_graph(2).parents
    end: dict[str, float] = {}
    for name in STAGES:
        end[name] = stages[name]["seconds"] + max((end[p] for p in PARENTS[name] if p in end), default=0.0)
    return max(end.values())


def size_of(shot: Path) -> str:
    from ops.shotio.load import load_shot

    s = load_shot(shot)
    return f"{s.size[1]}x{s.size[0]}x{len(s.times)}"


def print_samples(results: dict[str, dict]) -> None:
    print(f"\n{'shot':14s} {'size':>11s} | {'cold s':>7s} {'cpu':>6s} {'stages':>6s} {'ovh':>5s} {'ovh-cp':>6s} | "
          f"{'warm s':>6s} {'cpu':>5s} {'torch':>5s} | {'edit s':>6s} {'cpu':>5s} {'ran':>3s} | {'R s':>5s} {'cpu':>5s} "
          f"{'Ro s':>5s} {'cpu':>5s} | {'cold/R':>6s} {'warm/R':>6s} {'edit/R':>6s} {'cold/Ro':>7s} {'edit/Ro':>7s} | "
          f"{'rss MB':>6s}")
    for name, r in results.items():
        c, w, e, rd, ro = r["cold"], r["warm"], r["edit"], r["rife"], r["rife_ort"]
        stages = sum(s["seconds"] for s in r["report"]["stages"].values())
        chain = critical_path(r["report"]["stages"])
        ran = sum(1 for s in r["edited"]["stages"].values() if not s["cached"]) if e else 0
        edit = f"{e['wall']:6.1f} {e['cpu']:5.1f} {ran:3d}" if e else f"{'-':>6s} {'-':>5s} {'-':>3s}"
        edit_ratio = f"{e['wall'] / rd['wall']:6.2f}" if e else f"{'-':>6s}"
        edit_ratio_o = f"{e['wall'] / ro['wall']:7.2f}" if e else f"{'-':>7s}"
        print(f"{name:14s} {r['size']:>11s} | {c['wall']:7.1f} {c['cpu']:6.1f} {stages:6.1f} {c['wall'] - stages:5.1f} {c['wall'] - chain:6.1f} | "
              f"{w['wall']:6.2f} {w['cpu']:5.2f} {'yes' if w['torch'] else 'no':>5s} | {edit} | {rd['wall']:5.1f} {rd['cpu']:5.1f} "
              f"{ro['wall']:5.1f} {ro['cpu']:5.1f} | {c['wall'] / rd['wall']:6.2f} {w['wall'] / rd['wall']:6.2f} {edit_ratio} "
              f"{c['wall'] / ro['wall']:7.2f} {edit_ratio_o} | {c['rss_max'] / 2**20:6.0f}")
    print("X/R: run X's wall seconds over RIFE-direct's (a new process: the network loaded, the keys bisected to "
          "every output time) on the same shot in this run, the network run by torch (R) or ONNX Runtime (Ro)")
    for name, r in results.items():
        u = r["used"]
        print(f"{name}: cold run of a second shot in the same home (its Dagster instance already made): "
              f"{u['wall']:.1f} s ({u['cpu']:.1f} s CPU), {u['wall'] / r['rife']['wall']:.2f}x R, "
              f"{u['wall'] / r['rife_ort']['wall']:.2f}x Ro")
    for name, r in results.items():
        if len(r.get("rounds", [])) > 1:
            cols = ("cold/R", "cold/Ro", "used/R", "used/Ro", "edit/R", "edit/Ro")
            print(f"{name}: {len(r['rounds'])} rounds (the median round, by cold/Ro, above): "
                  + "; ".join(f"{c} " + " ".join(f"{x[c]:.2f}" for x in r["rounds"]) for c in cols))


def print_stage_split(results: dict[str, dict]) -> None:
    names = list(next(iter(results.values()))["report"]["stages"])
    print(f"\n{'cold run, stage seconds':28s} " + " ".join(f"{n[:12]:>12s}" for n in results))
    for stage in names:
        print(f"{stage:28s} " + " ".join(f"{r['report']['stages'][stage]['seconds']:12.2f}" for r in results.values()))


def scaled_shot(src: Path, dst: Path, size: int, frames: int | None) -> Path:
    """A copy of src resized to `size` px; with `frames`, only the key poses kept and `frames` set."""
    from ops.shotio.image_io import image_size
    from tests.assets.conftest import scaled_copy

    h, _ = image_size(src / "key0.png")
    shot = scaled_copy(src, dst, size / h)
    if frames is not None:
        data = json.loads((shot / "shot.json").read_text())
        data["poses"] = [data["poses"][0], data["poses"][-1]]
        data["frames"] = frames
        data.pop("ground_truth", None)
        (shot / "shot.json").write_text(json.dumps(data, indent=1))
    return shot


def print_scaling(src: Path, tmp: Path, sizes: list[int], frame_counts: list[int]) -> None:
    print(f"\nscaling ({src.name}) {'':8s} | {'cold s':>7s} {'cpu':>6s} {'rife s':>7s} {'lanes s':>7s} | {'rss MB':>6s}")
    cases = [(s, None) for s in sizes] + [(384, f) for f in frame_counts]
    for size, frames in cases:
        label = f"{size} px, " + (f"{frames} frames" if frames else "9 frames (all poses)")
        shot = scaled_shot(src, tmp / "scaling" / f"{size}-{frames}" / src.name, size, frames)
        out = tmp / "scaling-out" / f"{size}-{frames}"
        r = cli(["run", str(shot), "--out", str(out)], tmp / "scaling-home" / f"{size}-{frames}")
        st = json.loads((out / "report.json").read_text())["stages"]
        # the keys' stages and each segment's side stages (seg0/key1/deformed_frames); the matrix of every segment
        lanes = sum(v["seconds"] for k, v in st.items() if any(part.startswith("key") for part in k.split("/")))
        rife = sum(v["seconds"] for k, v in st.items() if k.endswith("rife_matrix"))
        print(f"{label:28s} | {r['wall']:7.1f} {r['cpu']:6.1f} {rife:7.1f} {lanes:7.1f} | "
              f"{r['rss_max'] / 2**20:6.0f}", flush=True)


def extra_junctions(home: Path, partition: str, count: int) -> tuple[int, list[list[float]]]:
    """(key, count (x, y) pixels) T-junctions to add: on the occlusion boundaries of the key with more boundary
    (refined masks of a run in `home`), each in the middle of the longest stretch of boundary left without a
    junction, so the clicks spread over the regions and along them."""
    from resources.store import Store

    store = Store(home / "storage")
    refined = [store.read(f"key{k}/refined_masks", partition) for k in (0, 1)]
    length = [sum(float(np.linalg.norm(np.diff(b, axis=0, append=b[:1]), axis=1).sum()) for b in r.boundaries)
              for r in refined]
    k = int(np.argmax(length))
    if not refined[k].boundaries:
        raise RuntimeError(f"{partition} has no occlusion region to click on")
    loops = []  # per region: closed-polyline arc lengths of the vertices, the perimeter, the junctions' arc lengths
    for b, jn in zip(refined[k].boundaries, refined[k].junctions):
        seg = np.linalg.norm(np.diff(b, axis=0, append=b[:1]), axis=1)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        loops.append((b, arc, list(arc[np.asarray(jn, np.int64)])))
    added = []
    for _ in range(count):
        best = None
        for r, (_, arc, cuts) in enumerate(loops):
            marks = sorted(cuts) or [0.0]  # a loop without junctions: one stretch, the whole perimeter
            gaps = np.diff(marks + [marks[0] + arc[-1]])
            g = int(np.argmax(gaps))
            if best is None or gaps[g] > best[0]:
                best = (float(gaps[g]), r, (marks[g] + gaps[g] / 2) % arc[-1])
        _, r, s = best
        b, arc, cuts = loops[r]
        i = int(np.searchsorted(arc, s, side="right") - 1)
        u = (s - arc[i]) / max(arc[i + 1] - arc[i], 1e-12)
        added.append((b[i] + u * (b[(i + 1) % len(b)] - b[i])).tolist())
        cuts.append(s)
    return k, added


class _HidingStore:
    """A store whose one stage's stored output reads as missing: that stage computes as in a cold home (the
    template stage keeps an earlier template's cuts when it finds one, and searches nothing)."""

    def __init__(self, store, hidden: str):
        self._store, self._hidden = store, hidden

    def read(self, name: str, partition: str):
        if name == self._hidden:
            raise KeyError(name)
        return self._store.read(name, partition)

    def __getattr__(self, name: str):
        return getattr(self._store, name)


def compute_alone(home: Path, shot_dir: Path, name: str):
    """(StageResult, CPU seconds) of computing stage `name` of the shot in this process, from the parents a run
    stored in `home`, with the code checked out now (its own stored output reads as missing)."""
    from types import SimpleNamespace

    from assets import stages  # noqa: F401  (declares every stage)
    from assets.compute import STAGE_SPECS, StageEnv
    from ops.settings import RecordingSettings, Settings
    from ops.shotio.load import load_shot
    from resources.inpainter import InpainterResource
    from resources.rife import RifeResource
    from resources.store import Store

    log = SimpleNamespace(info=lambda *a, **k: None, warning=lambda *a, **k: None, debug=lambda *a, **k: None)
    context = SimpleNamespace(resources=SimpleNamespace(inpainter=InpainterResource(), rife=RifeResource()), log=log)
    env = StageEnv(context, shot_dir.name, _HidingStore(Store(home / "storage"), name), None,
                   RecordingSettings(Settings()), stage=name)
    env.__dict__["shot"] = load_shot(shot_dir)
    start = time.process_time()
    result = STAGE_SPECS[name].compute(env)
    return result, time.process_time() - start


def stage_cpu(home: Path, shot_dir: Path, name: str, repeats: int = 2) -> float:
    """The least CPU seconds, over `repeats`, of computing stage `name` of the shot in this process, from the
    parents a run stored in `home`: the stage alone, with no other lane beside it on the cores."""
    return min(compute_alone(home, shot_dir, name)[1] for _ in range(repeats))


def print_added_junctions(src: Path, tmp: Path, count: int, rounds: int = 1) -> None:
    """Cold runs of a shot and of the shot with `count` more T-junctions, `rounds` times in turn: per stage the
    median seconds and their ratio (a stage's seconds are wall time beside the other lane's stages on 2 cores,
    so one round's ratio of a short stage swings 0.4-2x; the median of several rounds is what to read)."""
    base = shutil.copytree(src, tmp / "junctions" / "before" / src.name)
    shot = tmp / "junctions" / "after" / src.name
    walls, stages = {"before": [], "after": []}, {"before": [], "after": []}
    for i in range(rounds):
        for case in ("before", "after"):
            home, out = tmp / f"junctions-home-{case}-{i}", tmp / f"junctions-out-{case}-{i}"
            if case == "after" and i == 0:
                k, points = extra_junctions(tmp / "junctions-home-before-0", src.name, count)
                shutil.copytree(src, shot)
                data = json.loads((shot / "shot.json").read_text())
                data["t_junctions"][k] = list(data["t_junctions"][k]) + points
                (shot / "shot.json").write_text(json.dumps(data, indent=1))
            r = cli(["run", str(base if case == "before" else shot), "--out", str(out)], home)
            walls[case].append(r["wall"])
            stages[case].append(json.loads((out / "report.json").read_text())["stages"])
    n = len(data["t_junctions"][k])
    before, after = float(np.median(walls["before"])), float(np.median(walls["after"]))
    print(f"\nadding {count} T-junctions to {src.name}'s key{k} ({n - count} -> {n}), {rounds} round(s), medians: "
          f"cold run {before:.1f} s -> {after:.1f} s, {after / before:.2f}x")
    # wall seconds beside the other lane, and the stage's own CPU seconds in the same runs (report.json's
    # cpu_seconds: what the stage costs, whatever runs beside it)
    print(f"{'stage':28s} {'before s':>8s} {'after s':>8s} {'ratio':>6s}  {'cpu before':>10s} {'cpu after':>9s} "
          f"{'ratio':>6s}  wall ratio per round")
    for stage in stages["before"][0]:
        a = [st[stage]["seconds"] for st in stages["before"]]
        b = [st[stage]["seconds"] for st in stages["after"]]
        ca = float(np.median([st[stage]["cpu_seconds"] for st in stages["before"]]))
        cb = float(np.median([st[stage]["cpu_seconds"] for st in stages["after"]]))
        ma, mb = float(np.median(a)), float(np.median(b))
        each = " ".join(f"{y / x:.2f}" if x > 0.005 else "nan" for x, y in zip(a, b))
        print(f"{stage:28s} {ma:8.2f} {mb:8.2f} {mb / ma if ma > 0.005 else float('nan'):6.2f}  {ca:10.2f} {cb:9.2f} "
              f"{cb / ca if ca > 0.005 else float('nan'):6.2f}  {each}")
    # the stages the clicks rerun, each alone in this process: CPU seconds without the other lane's contention
    names = [f"key{k}/refined_masks", f"key{k}/template", f"seg0/key{k}/textured_template",
             f"seg0/key{k}/deformed_frames", "seg0/rife_matrix"]
    print("\nthe same stages computed alone in one process, least CPU seconds of 2 (no other lane beside them)")
    print(f"{'stage':28s} {'before s':>8s} {'after s':>8s} {'ratio':>6s}")
    for name in names:
        a = stage_cpu(tmp / "junctions-home-before-0", base, name)
        b = stage_cpu(tmp / "junctions-home-after-0", shot, name)
        print(f"{name:28s} {a:8.2f} {b:8.2f} {b / a:6.2f}", flush=True)


# the "adding 5 T-junctions" shots: a lone region's 2 -> 7 (arm_cross's key1: the most probes per click), 11 -> 16
# where a region turns odd and 8 of its 9 probes are deformed from rest (curled_tail), and 8 -> 13, the issue's own count
ADD_JUNCTIONS = ("arm_cross", "curled_tail", "hand_on_hip")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shots", default=str(ROOT / "data_samples"))
    ap.add_argument("--only", nargs="*", default=list(ORIGINAL), help="sample shots for the per-sample table")
    ap.add_argument("--sizes", type=int, nargs="*", default=[256, 384, 512, 1024])
    ap.add_argument("--frames", type=int, nargs="*", default=[5, 9, 17, 33])
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--no-batch", action="store_true")
    ap.add_argument("--add-junctions", nargs="*", default=list(ADD_JUNCTIONS),
                    help="shots of the 'adding 5 T-junctions' case")
    ap.add_argument("--no-add-junctions", action="store_true")
    ap.add_argument("--rounds", type=int, default=1, help="repeat each sample's cold run, RIFE-direct and edit in turn "
                    "this many times, and the added T-junctions case's two runs (a shared machine: the median round is reported, "
                    "every round's ratios printed)")
    args = ap.parse_args()
    print(f"{load()}, {os.cpu_count()} CPUs; times in seconds; cpu = user + sys of the process")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        results = {}
        for name in args.only:
            src = Path(args.shots) / name
            results[name] = run_sample(src, tmp, args.rounds)
            results[name]["size"] = size_of(src)
            print(f"  {name} done ({load()})", file=sys.stderr, flush=True)
        if results:  # `--only` with no shot: only the sections below
            print_samples(results)
            print_stage_split(results)
        if not args.no_add_junctions:
            for name in args.add_junctions:
                (tmp / f"added-{name}").mkdir()
                print_added_junctions(Path(args.shots) / name, tmp / f"added-{name}", 5, args.rounds)
        if not args.no_scaling:
            print_scaling(Path(args.shots) / "arm_cross", tmp, args.sizes, args.frames)
        if not args.no_batch:
            root = tmp / "batch-shots"
            root.mkdir()
            for name in args.only:
                shutil.copytree(Path(args.shots) / name, root / name)
            b = cli(["batch", str(root), "--out", str(tmp / "batch-out")], tmp / "batch-home")
            print(f"\nbatch of {len(args.only)} shots (2 workers): {b['wall']:.1f} s wall, "
                  f"peak RSS {b['rss_max'] / 2**20:.0f} MB largest process, {b['rss_sum'] / 2**20:.0f} MB all processes")
    print(load())


if __name__ == "__main__":
    main()
