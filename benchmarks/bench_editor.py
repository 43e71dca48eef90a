"""The editor's two interactive numbers, measured through its HTTP API as the page calls it:

1. live re-pose latency: one drag update = POST /api/repose with the pose after a 3 px pointer move, answered
   with the template deformed into it (bounded warm-started solve + render at display size + HTTP, raw RGBA
   as the page asks), over 100 drag updates (10 drags of 10 moves, each on another joint of an in-between
   pose); and the settling update sent when each drag ends;
2. save to refreshed frames after a key1 T-junction edit (moved by --move px, default 3): PUT /api/shot, the
   background rerun, and every output frame fetched again, as the page does when the rerun reports done; with
   the CPU seconds of the rerun process (and its children), which a loaded machine does not stretch, and what
   the rerun panel said while rife_matrix ran (its progress events). Each save comes --think s (default 10: a
   person making the fix) after the editor started or its last rerun ended, and is measured --rounds times
   (default 2) with the rerun made ready ahead (the editor's standby, assets/run/reruns.py) and without it
   (INBETWEEN_STANDBY=0), alternately, each in an editor of its own, and after each pair RIFE-direct on the same
   shot as a new process (ONNX Runtime, as bench_pipeline.py's Ro): the saves are printed as ratios to it too,
   since machines of this kind differ up to 2.7x per core.

    python benchmarks/bench_editor.py [--shot data_samples/arm_cross] [--scale 1.0] [--home DIR]
                                      [--only repose|save|watch]
                                      [--move 3] [--think 10] [--rounds 2]

3. the same edit saved outside the editor (`--only watch`): shot.json written while `inbetween watch` follows the
   shot, to its `saved: done` line (its reruns are the editor's, standby included), against `inbetween run` as a
   new process after the same edit, alternately, each --think s after the watch started or the last run ended,
   and RIFE-direct after each pair.

The shot is copied into a temporary folder and run cold once (printed too), so its templates are cached;
the editor is then started as `python -m editor SHOT --port 0 --no-browser` in its own process, the way
`inbetween edit` runs it. --home reuses a store from an earlier run of this benchmark (skips the cold run).
"""
from __future__ import annotations

import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)

# isort: split
import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
JOINTS = ("r_hand", "l_hand", "r_elbow", "l_foot", "r_foot", "head", "l_elbow", "r_knee", "l_knee", "neck")


def env_for(home: Path) -> dict:
    return {**os.environ, "INBETWEEN_HOME": str(home), "DAGSTER_HOME": str(home / "dagster"),
            "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}


def request(url: str, method: str = "GET", data=None):
    body = json.dumps(data).encode() if data is not None else None
    req = urllib.request.Request(url, data=body, method=method, headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=600) as r:
        return r.read(), r.headers  # case-insensitive


def percentiles(ms: list[float]) -> str:
    return f"median {np.median(ms):6.1f} ms   p95 {np.percentile(ms, 95):6.1f} ms   max {max(ms):6.1f} ms"


def repose_latency(url: str, shot: dict, drags: int, moves: int) -> None:
    motion = json.loads(request(url + "/api/motion", "POST", {})[0])
    i = len(motion["times"]) // 2
    t, pose = motion["times"][i], np.asarray(motion["poses"][i])
    names = shot["skeleton"]["joints"]
    request(url + "/api/repose", "POST", {"k": 1, "t": t, "joints": pose.tolist(), "scale": 1.0})  # load + factorize
    total, solve, render, iters, settle, cpu = [], [], [], [], [], []
    rng = np.random.default_rng(0)
    for d in range(drags):
        j = names.index(JOINTS[d % len(JOINTS)]) if JOINTS[d % len(JOINTS)] in names else d % len(names)
        direction = rng.normal(size=2)
        direction *= 3.0 / np.linalg.norm(direction)  # a pointer move of 3 px per update
        for _ in range(moves):
            pose[j, :2] += direction
            t0 = time.perf_counter()
            _, headers = request(url + "/api/repose", "POST", {"k": 1, "t": t, "joints": pose.tolist(), "scale": 1.0,
                                                               "settle": False, "format": "rgba"})  # as the page asks
            total.append((time.perf_counter() - t0) * 1e3)
            solve.append(float(headers["X-Solve-Ms"]))
            render.append(float(headers["X-Render-Ms"]))
            iters.append(int(headers["X-Iterations"]))
            cpu.append(float(headers["X-Cpu-Ms"]))
        t0 = time.perf_counter()  # pointer released: the settling update
        request(url + "/api/repose", "POST", {"k": 1, "t": t, "joints": pose.tolist(), "scale": 1.0, "format": "rgba"})
        settle.append((time.perf_counter() - t0) * 1e3)
    print(f"live re-pose, {len(total)} drag updates at t = {t:.3f} on key1's template, rendered at the shot's size:")
    print(f"  update (HTTP round trip)  {percentiles(total)}")
    print(f"  solve (warm-started)      {percentiles(solve)}   iterations median {np.median(iters):.0f}")
    print(f"  render                    {percentiles(render)}")
    print(f"  CPU time of solve+render  {percentiles(cpu)}   (all threads of the server; a loaded machine "
          "stretches the wall times above, not this)")
    print(f"  settling update at the end of each of the {drags} drags: {percentiles(settle)}")


def _cpu_seconds(pid: int) -> float | None:
    """CPU seconds (user + system) of process pid and of its children it has waited for, from /proc."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return sum(int(v) for v in fields[11:15]) / os.sysconf("SC_CLK_TCK")  # utime stime cutime cstime


def save_to_frames(url: str, shot_dir: Path, home: Path, move: float) -> float:
    shot = json.loads(request(url + "/api/shot")[0])
    shot["t_junctions"][1][0][0] += move
    partition = json.loads(request(url + "/api/info")[0])["partition"]
    t0 = time.perf_counter()
    request(url + "/api/shot", "PUT", shot)
    t_put = time.perf_counter() - t0
    cpu, pid, said = None, None, []
    while True:
        status = json.loads(request(url + "/api/status")[0])
        if status["state"] != "running":
            break
        try:
            pid = json.loads((home / "editor" / partition / "rerun.json").read_text()).get("pid")
        except (OSError, ValueError):
            pass
        cpu = (_cpu_seconds(pid) if pid else None) or cpu  # the last reading before the process exits
        p = status.get("stage_progress")
        line = f"{status['running_stage']} {p['done']}/{p['bound']}" if p else str(status["running_stage"])
        if not said or said[-1] != line:
            said.append(line)
        time.sleep(0.1)
    if status["state"] != "done":
        raise SystemExit(f"the rerun failed: {status['error']}")
    info = json.loads(request(url + "/api/frames")[0])
    for i in range(info["count"]):
        request(url + f"/api/frames/{i}.png?v={info['version']}")
    total = time.perf_counter() - t0
    ran = {n: s["seconds"] for n, s in status["stages"].items() if not s["cached"]}
    log = json.loads((home / "editor" / partition / "rerun.json").read_text()).get("log", "")
    standby = Path(log).name.startswith("standby-")  # the editor's standby ran it (assets/run/reruns.py)
    print(f"save -> refreshed frames after moving a key1 T-junction by {move:g} px, run "
          f"{'in the standby' if standby else 'in a new process'}: {total:.1f} s "
          f"(PUT answered in {t_put * 1e3:.0f} ms; rerun {status['finished'] - status['started']:.1f} s; "
          f"CPU of the rerun process >= {cpu or 0:.1f} s{' (its warm-up included)' if standby else ''}; "
          f"load average {os.getloadavg()[0]:.1f} at the end)")
    rife = [s for s in said if s.split(" ")[0].endswith("rife_matrix")]  # seg0/rife_matrix 5/9
    if rife:
        print(f"  while rife_matrix ran the panel named it with {len(rife)} different progress states: "
              f"{rife[0]!r} first, {rife[-1]!r} last")
    print(f"  stages re-run: {len(ran)} of {len(status['stages'])}, stage seconds {sum(ran.values()):.1f}: "
          + ", ".join(f"{n} {s:.2f}" for n, s in ran.items()))
    return total


def move_junction(shot_dir: Path, move: float) -> None:
    """Move key1's first T-junction `move` px right in shot.json (written in one call, as an editor saves)."""
    data = json.loads((shot_dir / "shot.json").read_text())
    x, y = data["t_junctions"][1][0]
    data["t_junctions"][1][0] = [x + move, y]
    (shot_dir / "shot.json").write_text(json.dumps(data, indent=1))


def watch_to_frames(shot_dir: Path, home: Path, out: Path, move: float, think: float) -> float:
    """Seconds from a T-junction edit saved to shot.json to `inbetween watch`'s `saved: done` line."""
    proc = subprocess.Popen([sys.executable, "-m", "assets.cli", "watch", str(shot_dir), "--out", str(out)],
                            env={**env_for(home), "PYTHONUNBUFFERED": "1"}, cwd=ROOT, stdout=subprocess.PIPE,
                            text=True)
    try:
        for line in proc.stdout:  # its first run: every stage fresh but the outputs written
            if line.startswith("start: "):
                break
        time.sleep(think)
        move_junction(shot_dir, move)
        t0 = time.perf_counter()
        for line in proc.stdout:
            if line.startswith("saved: "):
                took = time.perf_counter() - t0
                if not line.startswith("saved: done"):
                    raise RuntimeError(line.strip())
                return took
        raise RuntimeError("inbetween watch ended before the rerun did")
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(60)


def run_to_frames(shot_dir: Path, home: Path, out: Path, move: float, think: float) -> float:
    """Seconds of `inbetween run` as a new process after the same edit, --think s after the last run."""
    time.sleep(think)
    move_junction(shot_dir, move)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "assets.cli", "run", str(shot_dir), "--out", str(out)], env=env_for(home),
                   cwd=ROOT, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def editor(shot_dir: Path, home: Path, standby: bool) -> tuple[subprocess.Popen, str]:
    """An editor server of the shot in its own process (as `inbetween edit` runs it) and its URL."""
    env = {**env_for(home), "INBETWEEN_STANDBY": "1" if standby else "0"}
    proc = subprocess.Popen([sys.executable, "-m", "editor", str(shot_dir), "--port", "0", "--no-browser"],
                            env=env, cwd=ROOT, stdout=subprocess.PIPE, text=True)
    return proc, re.search(r"http://127\.0\.0\.1:\d+", proc.stdout.readline()).group(0)


def close(proc: subprocess.Popen) -> None:
    proc.send_signal(signal.SIGINT)
    proc.wait(30)


def main() -> None:
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs at the start")
    ap = argparse.ArgumentParser()
    ap.add_argument("--shot", default=str(ROOT / "data_samples" / "arm_cross"))
    ap.add_argument("--scale", type=float, default=1.0, help="resize the shot first (1.0: as is, 384 px for arm_cross)")
    ap.add_argument("--home", default=None, help="reuse this benchmark's folder from an earlier run")
    ap.add_argument("--drags", type=int, default=10)
    ap.add_argument("--moves", type=int, default=10)
    ap.add_argument("--only", choices=["repose", "save", "watch"], default=None)
    ap.add_argument("--move", type=float, default=3.0, help="px the key1 T-junction moves before the save")
    ap.add_argument("--think", type=float, default=10.0, help="s from the editor's start to the save")
    ap.add_argument("--rounds", type=int, default=2, help="saves with the standby and without it, alternately")
    args = ap.parse_args()
    base = Path(args.home) if args.home else Path(tempfile.mkdtemp(prefix="bench_editor-"))
    shot_dir, home = base / "shots" / Path(args.shot).name, base / "home"
    if not shot_dir.exists():
        if args.scale != 1.0:
            sys.path.insert(0, str(ROOT))
            from tests.assets.conftest import scaled_copy

            scaled_copy(Path(args.shot), shot_dir, args.scale)
        else:
            shutil.copytree(args.shot, shot_dir)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "assets.cli", "run", str(shot_dir), "--out", str(base / "out")],
                       env=env_for(home), cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
        print(f"cold run of {shot_dir.name} (to fill the store): {time.perf_counter() - t0:.1f} s")
    from ops.shotio.image_io import image_size

    h, w = image_size(shot_dir / "key0.png")
    print(f"shot {shot_dir.name}, {w}x{h} px, {os.cpu_count()} CPUs; folder {base}")
    if args.only in (None, "repose"):
        proc, url = editor(shot_dir, home, standby=True)
        try:
            repose_latency(url, json.loads(request(url + "/api/shot")[0]), args.drags, args.moves)
        finally:
            close(proc)
    if args.only in (None, "save"):
        sys.path.insert(0, str(ROOT))
        from benchmarks.bench_pipeline import rife_direct

        times: dict[bool, list[float]] = {True: [], False: []}
        ratios: dict[bool, list[float]] = {True: [], False: []}
        for _ in range(args.rounds):
            pair = {}
            for standby in (True, False):
                proc, url = editor(shot_dir, home, standby)
                try:
                    time.sleep(args.think)
                    pair[standby] = save_to_frames(url, shot_dir, home, args.move)
                finally:
                    close(proc)
            ro = rife_direct(shot_dir, base / "rife_direct", base / "rife_home", "onnxruntime")["wall"]
            print(f"RIFE-direct (ONNX Runtime) on the same shot: {ro:.1f} s")
            for standby, t in pair.items():
                times[standby].append(t)
                ratios[standby].append(t / ro)
        for standby in (True, False):
            print(f"save -> refreshed frames, {'with' if standby else 'without'} the standby: "
                  + " ".join(f"{t:.1f}" for t in times[standby]) + f" s (median {np.median(times[standby]):.1f}); "
                  + "/ RIFE-direct " + " ".join(f"{r:.2f}" for r in ratios[standby]))

    if args.only in (None, "watch"):
        sys.path.insert(0, str(ROOT))
        from benchmarks.bench_pipeline import rife_direct

        kinds = {"inbetween watch": watch_to_frames, "inbetween run": run_to_frames}
        got: dict[str, list[tuple[float, float]]] = {k: [] for k in kinds}
        for _ in range(args.rounds):
            pair = {kind: fn(shot_dir, home, base / "out", args.move, args.think) for kind, fn in kinds.items()}
            ro = rife_direct(shot_dir, base / "rife_direct", base / "rife_home", "onnxruntime")["wall"]
            print(f"RIFE-direct (ONNX Runtime) on the same shot: {ro:.1f} s")
            for kind, t in pair.items():
                got[kind].append((t, t / ro))
        for kind, runs in got.items():
            print(f"edit saved -> frames, {kind}: " + " ".join(f"{t:.1f}" for t, _ in runs) + " s; / RIFE-direct "
                  + " ".join(f"{r:.2f}" for _, r in runs))


if __name__ == "__main__":
    main()
