"""A stand-in for `inbetween run` in the rerun tests: same progress events, report and error line, no pipeline.

usage: fake_run.py PARTITION OUT_DIR [--sleep S] [--fail] [--stages a,b,c]
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
    args = p.parse_args()
    progress = os.environ["INBETWEEN_PROGRESS"]
    stages = args.stages.split(",")
    for i, stage in enumerate(stages):
        with open(progress, "a") as f:
            f.write(json.dumps({"partition": args.partition, "stage": stage, "event": "start"}) + "\n")
        time.sleep(args.sleep)
        if args.fail and i == len(stages) - 1:
            print(f"error: {args.partition}: {stage}: fake failure (full log: nowhere)", file=sys.stderr)
            return 1
        with open(progress, "a") as f:
            f.write(json.dumps({"partition": args.partition, "stage": stage, "event": "done", "cached": i == 0,
                                "seconds": 0.01 * i}) + "\n")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    report = {"frames": 3, "frames_version": "fake", "stages": {s: {"executed": True, "cached": i == 0, "seconds": 0.01 * i}
                                                                for i, s in enumerate(stages)}}
    (out / "report.json").write_text(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
