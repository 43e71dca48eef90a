"""A stand-in for `inbetween run` in the rerun tests: same progress events, report and error line, no pipeline.

usage: fake_run.py PARTITION OUT_DIR [--sleep S] [--fail] [--stages a,b,c] [--ahead] [--standby]

--ahead plays the work-ahead's order (assets/ahead.py): the last stage starts before the others' steps report
"done", and reports its progress (done of at most bound blends) as rife_matrix does.

--standby plays assets/standby.py: it prints `ready`, then waits for one line on stdin (a JSON object of
environment variables) and runs; at the end of input without a line it exits 0 and writes nothing.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

STAGES = "key1/refined_masks,key1/template,seg0/rife_matrix,inbetween_frames"


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("partition")
    p.add_argument("out")
    p.add_argument("--sleep", type=float, default=0.05)
    p.add_argument("--fail", action="store_true")
    p.add_argument("--stages", default=STAGES)
    p.add_argument("--ahead", action="store_true")
    p.add_argument("--standby", action="store_true")
    args = p.parse_args()
    if args.standby:
        print("ready", flush=True)
        line = sys.stdin.readline()
        if not line.strip():
            return 0
        os.environ.update(json.loads(line))
    progress = os.environ["INBETWEEN_PROGRESS"]
    stages = args.stages.split(",")

    def emit(stage: str, event: str, **fields) -> None:
        with open(progress, "a") as f:
            f.write(json.dumps({"time": time.time(), "partition": args.partition, "stage": stage, "event": event,
                                **fields}) + "\n")

    if args.ahead:
        *early, last = stages
        for stage in early:
            emit(stage, "start")
        emit(last, "start")  # computed ahead: it starts before the earlier steps report
        for i, stage in enumerate(early):
            time.sleep(args.sleep)
            emit(stage, "done", cached=i == 0, seconds=0.01 * i)
        for n in range(1, 4):
            time.sleep(args.sleep)
            emit(last, "progress", done=n, bound=4)
        time.sleep(args.sleep)
        emit(last, "done", cached=False, seconds=0.01 * len(early))
    for i, stage in enumerate(stages if not args.ahead else []):
        emit(stage, "start")
        time.sleep(args.sleep)
        if args.fail and i == len(stages) - 1:
            print(f"error: {args.partition}: {stage}: fake failure (full log: nowhere)", file=sys.stderr)
            return 1
        emit(stage, "done", cached=i == 0, seconds=0.01 * i)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    report = {"frames": 3, "frames_version": "fake", "stages": {s: {"executed": True, "cached": i == 0, "seconds": 0.01 * i}
                                                                for i, s in enumerate(stages)}}
    (out / "report.json").write_text(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
