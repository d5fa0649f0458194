#!/usr/bin/python3
"""Assembles scripts/bench.sh's measurements into OUT/bench.md and OUT/bench.json."""
import json
import os
import platform
import re
import statistics
import sys


def machine():
    model = "unknown"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    return {"cpu": model, "cores": os.cpu_count(), "kernel": platform.release()}


def main():
    out, repeat = sys.argv[1], int(sys.argv[2])
    rows = []
    micro = json.load(open(os.path.join(out, "micro.json")))
    for b in micro["benchmarks"]:
        if b.get("aggregate_name") == "median":
            rows.append({"what": b["run_name"], "median_ms": b["real_time"] if b["time_unit"] == "ms"
                         else b["real_time"] / 1e6, "counters": {k: v for k, v in b.items()
                         if k not in ("name", "run_name", "run_type", "repetitions", "threads",
                                      "aggregate_name", "aggregate_unit", "iterations", "real_time",
                                      "cpu_time", "time_unit", "family_index",
                                      "per_family_instance_index", "repetition_index")}})
    reg = {}
    for line in open(os.path.join(out, "e2e.txt")):
        _, key, value = line.split()
        reg.setdefault(key, []).append(float(value))
    e2e = {k: statistics.median(v) for k, v in reg.items()}
    runs = [json.load(open(os.path.join(out, "run_report_%d.json" % r))) for r in range(1, repeat + 1)]
    rss = []
    for r in range(1, repeat + 1):
        text = open(os.path.join(out, "run_time_%d.txt" % r)).read()
        rss.append(int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1)) / 1024)
    sims = [json.load(open(os.path.join(out, "simulate_report_%d.json" % r))) for r in range(1, repeat + 1)]
    total = statistics.median(r["seconds"]["total"] for r in runs)
    estimator = statistics.median(r["seconds"]["selection"] + r["seconds"]["filter"] for r in runs)
    seq_seconds = runs[0]["frames_total"] / 30.0
    sim_all = statistics.median(s["table"][0]["seconds"] for s in sims)
    sim_info = statistics.median(s["table"][1]["seconds"] for s in sims)
    summary = {
        "machine": machine(),
        "register_step5_ms_per_frame": e2e.get("register.ms_per_frame"),
        "run_7scenes_seconds": total,
        "run_7scenes_realtime_factor": seq_seconds / total,
        "run_7scenes_estimator_realtime_factor": seq_seconds / estimator if estimator > 0 else None,
        "run_7scenes_peak_rss_mb": statistics.median(rss),
        "run_7scenes_frames_selected": runs[0]["frames_selected"],
        "run_7scenes_ate_m": runs[0].get("ate_rmse_m"),
        "simulate_all_seconds": sim_all,
        "simulate_info3_seconds": sim_info,
        "simulate_time_ratio_info3_over_all": sim_info / sim_all,
        "micro": rows,
    }
    with open(os.path.join(out, "bench.json"), "w") as f:
        json.dump(summary, f, indent=2)
    lines = ["# ieslam benchmarks", "",
             "Machine: %s, %d cores. Medians of %d repetitions." % (summary["machine"]["cpu"],
                                                                    summary["machine"]["cores"], repeat),
             "", "| measurement | value |", "|---|---|"]
    for key in ("register_step5_ms_per_frame", "run_7scenes_seconds", "run_7scenes_realtime_factor",
                "run_7scenes_estimator_realtime_factor", "run_7scenes_peak_rss_mb",
                "run_7scenes_frames_selected", "simulate_all_seconds", "simulate_info3_seconds",
                "simulate_time_ratio_info3_over_all"):
        value = summary[key]
        lines.append("| %s | %s |" % (key, "%.3f" % value if isinstance(value, float) else value))
    lines += ["", "| micro-benchmark | median ms | counters |", "|---|---|---|"]
    for row in rows:
        lines.append("| %s | %.3f | %s |" % (row["what"], row["median_ms"],
                                              ", ".join("%s=%g" % kv for kv in row["counters"].items())))
    text = "\n".join(lines) + "\n"
    open(os.path.join(out, "bench.md"), "w").write(text)
    print(text)


if __name__ == "__main__":
    main()
