#!/usr/bin/python3
"""ATE and RPE of one run's filter (keyframes.tum) and refinement (refined.tum).

    evaluate.py IESLAM STATUS.json EVALUATION.json

Runs `ieslam evaluate` against the run's groundtruth.tum and writes EVALUATION.json:
{"ok", "filter": {key: value}, "refined": {...}, "error", "log_tail"}. A run that failed, a
missing ground truth or a failed evaluation is recorded, and the script still exits 0.
"""
import json
import os
import subprocess
import sys


def evaluate(ieslam, gt, est):
    result = subprocess.run(
        [ieslam, "evaluate", "--gt", gt, "--est", est], capture_output=True, text=True
    )
    if result.returncode != 0:
        raise RuntimeError(
            f"ieslam evaluate exited {result.returncode}: {(result.stdout + result.stderr)[-800:]}"
        )
    values = {}
    for line in result.stdout.splitlines():
        parts = line.split()
        if len(parts) == 2:
            try:
                values[parts[0]] = float(parts[1])
            except ValueError:
                pass
    return values


def main():
    ieslam, status_path, output = sys.argv[1:4]
    status = json.load(open(status_path))
    out = os.path.join(os.path.dirname(status_path), "out")
    evaluation = {"ok": False}
    if not status["ok"]:
        evaluation["error"] = f"the run exited {status['exit_code']}"
    else:
        gt = os.path.join(out, "groundtruth.tum")
        try:
            if not os.path.exists(gt):
                raise RuntimeError("the run wrote no groundtruth.tum")
            evaluation["filter"] = evaluate(ieslam, gt, os.path.join(out, "keyframes.tum"))
            refined = os.path.join(out, "refined.tum")
            if os.path.exists(refined):
                evaluation["refined"] = evaluate(ieslam, gt, refined)
            evaluation["ok"] = True
        except (RuntimeError, OSError) as e:
            evaluation["error"] = str(e)
    temp = output + ".tmp"
    with open(temp, "w") as f:
        json.dump(evaluation, f, indent=2)
    os.replace(temp, output)


if __name__ == "__main__":
    main()
