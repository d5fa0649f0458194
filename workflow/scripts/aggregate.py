#!/usr/bin/python3
"""One CSV line per run: what it was, whether it worked, and what came of it.

    aggregate.py RUNS.csv STATUS.json...

Each STATUS.json sits in a run's directory runs/DATASET/SELECTOR-bBUFFER-sSEED/ beside
evaluation.json and out/report.json (from wrapped.py, evaluate.py and `ieslam run`).
Columns ending in _s, rtf and peak_mem_mb are timings and memory, which differ between
identical runs; every other column is the same for the same inputs, options and seed.
"""
import csv
import json
import os
import sys

COLUMNS = [
    "dataset", "selector", "buffer", "seed", "ok", "failure",
    "frames_total", "frames_selected", "state_dim",
    "ate_filter_m", "rpe_trans_filter_m", "rpe_rot_filter_deg",
    "ate_refined_m", "rpe_trans_refined_m", "rpe_rot_refined_deg",
    "inside_2sigma_filter", "mean_nees_filter", "inside_2sigma_refined", "mean_nees_refined",
    "sequence_s", "total_s", "frontend_s", "selection_s", "filter_s", "ba_s", "wall_s",
    "rtf", "peak_mem_mb", "log_tail",
]


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def sequence_seconds(trajectory):
    """The processed frames' time span, one frame period included."""
    try:
        stamps = [float(line.split()[0]) for line in open(trajectory)
                  if line.strip() and not line.startswith("#")]
    except (OSError, ValueError, IndexError):
        return None
    if len(stamps) < 2:
        return None
    return (stamps[-1] - stamps[0]) * len(stamps) / (len(stamps) - 1)


def row_of(status_path):
    run_dir = os.path.dirname(status_path)
    combo = os.path.basename(run_dir)
    dataset = os.path.basename(os.path.dirname(run_dir))
    selector, buffer, seed = combo.split("-")
    row = {"dataset": dataset, "selector": selector, "buffer": int(buffer[1:]),
           "seed": int(seed[1:])}
    status = load(status_path) or {"ok": False, "exit_code": None, "log_tail": "no status"}
    evaluation = load(os.path.join(run_dir, "evaluation.json")) or {"ok": False}
    report = load(os.path.join(run_dir, "out", "report.json")) or {}
    row["ok"] = int(bool(status.get("ok")) and bool(evaluation.get("ok")))
    if not status.get("ok"):
        row["failure"] = f"run exited {status.get('exit_code')}"
        row["log_tail"] = status.get("log_tail", "")
    elif not evaluation.get("ok"):
        row["failure"] = "evaluation: " + evaluation.get("error", "?")
        row["log_tail"] = status.get("log_tail", "")
    row["wall_s"] = status.get("wall_seconds")
    if status.get("peak_rss_kb") is not None:
        row["peak_mem_mb"] = status["peak_rss_kb"] / 1024.0
    for key in ("frames_total", "frames_selected", "state_dim"):
        row[key] = report.get(key)
    seconds = report.get("seconds", {})
    for key in ("total", "frontend", "selection", "filter", "ba"):
        row[f"{key}_s"] = seconds.get(key)
    row["sequence_s"] = sequence_seconds(os.path.join(run_dir, "out", "trajectory.tum"))
    if row["sequence_s"] and seconds.get("total"):
        row["rtf"] = row["sequence_s"] / seconds["total"]
    for stage in ("filter", "refined"):
        values = evaluation.get(stage, {})
        row[f"ate_{stage}_m"] = values.get("ate.rmse")
        row[f"rpe_trans_{stage}_m"] = values.get("rpe.trans.rmse")
        row[f"rpe_rot_{stage}_deg"] = values.get("rpe.rot.rmse")
        consistency = report.get("consistency", {}).get(stage, {})
        row[f"inside_2sigma_{stage}"] = consistency.get("inside_2sigma")
        row[f"mean_nees_{stage}"] = consistency.get("mean_nees")
    return row


def main():
    output = sys.argv[1]
    rows = sorted((row_of(p) for p in sys.argv[2:]),
                  key=lambda r: (r["dataset"], r["selector"], r["buffer"], r["seed"]))
    temp = output + ".tmp"
    with open(temp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in COLUMNS})
    os.replace(temp, output)


if __name__ == "__main__":
    main()
