#!/usr/bin/python3
"""Assembles scripts/bench.sh's measurements into OUT/bench.md and OUT/bench.json.

Usage: bench_table.py OUT REPEAT QUICK
Every number is the median over the REPEAT repetitions; each row says which target (the
front end's, the run's speed and memory) it is checked against.
"""
import glob
import json
import os
import platform
import re
import statistics
import subprocess
import sys

FPS = 30.0  # 7-Scenes is 30 Hz


def read(path):
    with open(path) as f:
        return f.read()


def machine(out):
    model, mem_kb = "unknown", 0
    for line in read("/proc/cpuinfo").splitlines():
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
            break
    for line in read("/proc/meminfo").splitlines():
        if line.startswith("MemTotal:"):
            mem_kb = int(line.split()[1])
    try:
        opencv = subprocess.run(["pkg-config", "--modversion", "opencv4"], capture_output=True,
                                text=True, check=False).stdout.strip() or "unknown"
    except OSError:
        opencv = "unknown"

    def load(name):
        path = os.path.join(out, name)
        m = re.search(r"load average: ([\d.]+)", read(path)) if os.path.exists(path) else None
        return float(m.group(1)) if m else None

    def text(name):
        path = os.path.join(out, name)
        return read(path).strip() if os.path.exists(path) else None

    return {"cpu": model, "cores": os.cpu_count(), "memory_gb": round(mem_kb / 2**20, 1),
            "kernel": platform.release(), "opencv": opencv, "commit": text("commit.txt"),
            "load_1min_before": load("load_before.txt"), "load_1min_after": load("load_after.txt"),
            "bench_seconds": int(text("bench_seconds.txt") or 0)}


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def key_values(path):
    values = {}
    for line in read(path).splitlines():
        parts = line.split()
        if len(parts) == 2:
            values[parts[0]] = float(parts[1])
    return values


def time_v(path):
    """Wall seconds and peak RSS (MB) from /usr/bin/time -v."""
    text = read(path)
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", text).group(1)
    seconds = 0.0
    for part in wall.split(":"):
        seconds = seconds * 60 + float(part)
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1)) / 1024
    return seconds, rss


def micro_rows(out):
    rows = []
    for b in json.load(open(os.path.join(out, "micro.json")))["benchmarks"]:
        if b.get("run_type") == "aggregate" and b.get("aggregate_name") != "median":
            continue
        scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}[b["time_unit"]]
        counters = {k: v for k, v in b.items() if k not in (
            "name", "run_name", "run_type", "repetitions", "threads", "aggregate_name",
            "aggregate_unit", "iterations", "real_time", "cpu_time", "time_unit", "family_index",
            "per_family_instance_index", "repetition_index")}
        rows.append({"what": b["run_name"], "median_ms": b["real_time"] * scale,
                     "cpu_ms": b["cpu_time"] * scale, "counters": counters})
    return rows


def run_mode(out, mode, repeat):
    reports = [json.load(open(os.path.join(out, "run_%s_report_%d.json" % (mode, r))))
               for r in range(1, repeat + 1)]
    timed = [time_v(os.path.join(out, "run_%s_time_%d.txt" % (mode, r))) for r in range(1, repeat + 1)]
    frames = reports[0]["frames_total"]
    wall = median(t[0] for t in timed)
    sec = {k: median(r["seconds"].get(k) for r in reports)
           for k in ("total", "frontend", "selection", "filter", "load")}
    estimator = sec["selection"] + sec["filter"]
    return {
        "frames": frames,
        "wall_s": wall,
        "realtime_factor": frames / FPS / wall,
        "seconds": sec,
        "estimator_realtime_factor": frames / FPS / estimator if estimator > 0 else None,
        "peak_rss_mb": median(t[1] for t in timed),
        "frames_selected": reports[0]["frames_selected"],
        "state_dim": reports[0].get("state_dim"),
        "ate_rmse_m": reports[0].get("ate_rmse_m"),
    }


def simulate(out):
    sims = [json.load(open(p)) for p in sorted(glob.glob(os.path.join(out, "simulate_report_*.json")))]
    all_rows = [s["table"][0] for s in sims]
    info_rows = [s["table"][1] for s in sims]
    return {
        "all_seconds": median(r["seconds"] for r in all_rows),
        "info3_seconds": median(r["seconds"] for r in info_rows),
        "time_ratio": median(i["seconds"] / a["seconds"] for a, i in zip(all_rows, info_rows)),
        "dim_ratio": median(i["state_dim"] / a["state_dim"] for a, i in zip(all_rows, info_rows)),
        "frames_used_info3": median(r["frames_used"] for r in info_rows),
        "frames_total": all_rows[0]["frames_total"],
    }


def scale_run(out, name):
    """One scale run: its report's figures and /usr/bin/time's wall and peak RSS (MiB)."""
    path = os.path.join(out, "scale_%s_report.json" % name)
    if not os.path.exists(path):
        return None
    report = json.load(open(path))
    wall, rss = time_v(os.path.join(out, "scale_%s_time.txt" % name))
    frames = report["frames_total"]
    return {"frames": frames, "wall_s": wall, "realtime_factor": frames / FPS / wall,
            "peak_rss_mib": rss, "keyframes": report["frames_selected"],
            "state_dim": report.get("state_dim"), "seconds": report["seconds"],
            "last_to_first_quarter": report["seconds"].get("last_to_first_quarter"),
            "ate_rmse_m": report.get("ate_rmse_m") or {}}


def scale(out):
    names = ("rpy", "rpy_threads1", "synth600", "synth2000", "synth2000_threads1", "rpy_refine",
             "rpy_refine_interval1", "rpy_last_quarter", "synth2000_last_quarter")
    runs = {name: scale_run(out, name) for name in names}
    if runs["rpy"] is None:
        return None
    quarters = {}
    for name in ("rpy", "synth2000"):
        whole, alone = runs[name], runs[name + "_last_quarter"]
        if not whole or not alone:
            continue
        whole_q = whole["seconds"].get("per_frame_by_quarter") or []
        alone_q = alone["seconds"].get("per_frame_by_quarter") or []
        if len(whole_q) == 4 and alone_q and whole_q[0] > 0 and whole_q[3] > 0:
            # The quarters are equal in frames, so their mean is the run's cost per frame.
            alone_per_frame = sum(alone_q) / len(alone_q)
            if alone_per_frame <= 0:
                continue
            quarters[name] = {"map_size": whole_q[3] / alone_per_frame,
                              "content": alone_per_frame / whole_q[0]}
    short, long_ = runs["synth600"], runs["synth2000"]
    kb_per_frame = None
    if short and long_:
        dropped = (long_["frames"] - long_["keyframes"]) - (short["frames"] - short["keyframes"])
        if dropped > 0:
            kb_per_frame = (long_["peak_rss_mib"] - short["peak_rss_mib"]) * 1024 / dropped
    exact = os.path.join(out, "simulate_exact_report.json")
    exact_table = json.load(open(exact))["table"] if os.path.exists(exact) else None
    exact_ratios = None
    if exact_table:
        a, i = exact_table[0], exact_table[1]
        exact_ratios = {"time_ratio": i["seconds"] / a["seconds"],
                        "dim_ratio": i["state_dim"] / a["state_dim"]}
    return {"runs": runs, "kb_per_non_keyframe": kb_per_frame, "simulate_exact": exact_ratios,
            "last_quarter_split": quarters}


def localize(out, name):
    """Medians over the repetitions of `ieslam localize` in a map of the sequence's first half."""
    reports = [json.load(open(p)) for p in
               sorted(glob.glob(os.path.join(out, "localize_%s_report_*.json" % name)))]
    if not reports:
        return None
    walls = [time_v(p)[0] for p in
             sorted(glob.glob(os.path.join(out, "localize_%s_time_*.txt" % name)))]
    frames = reports[0]["frames_processed"]
    ate = [r.get("ate_rmse_m") or {} for r in reports]
    return {"frames": frames, "map_keyframes": reports[0]["map"]["keyframes"],
            "localized_share": median(r["localized_share"] for r in reports),
            "localized_by_map_share": median(r["localized_by_map_share"] for r in reports),
            "ate_map_frame_m": median(a.get("map_frame", float("nan")) for a in ate),
            "ate_aligned_m": median(a.get("aligned", float("nan")) for a in ate),
            "wall_s": median(walls), "realtime_factor": frames / FPS / median(walls),
            "load_map_s": median(r["seconds"]["load_map"] for r in reports)}


def continued(out, name):
    """`ieslam run --map` over the second half against one run over the whole sequence."""
    paths = [os.path.join(out, d, "report.json") for d in ("continue_" + name, "single_" + name)]
    if not all(os.path.exists(p) for p in paths):
        return None
    c, s = (json.load(open(p)) for p in paths)
    return {"keyframes": c["frames_selected"], "map_keyframes": c["continued_map"]["keyframes"],
            "load_map_s": c["continued_map"]["load_seconds"],
            "ate_keyframes_m": c.get("ate_rmse_m", {}).get("keyframes", float("nan")),
            "single_keyframes": s["frames_selected"],
            "single_ate_keyframes_m": s.get("ate_rmse_m", {}).get("keyframes", float("nan"))}


def fmt(value, digits=3):
    if value is None:
        return "–"
    if isinstance(value, float):
        return ("%%.%df" % digits) % value
    return str(value)


def main():
    out, repeat, quick = sys.argv[1], int(sys.argv[2]), len(sys.argv) > 3 and sys.argv[3] == "1"
    micro = micro_rows(out)
    by_name = {row["what"]: row for row in micro}
    register5 = [key_values(p) for p in sorted(glob.glob(os.path.join(out, "register5_*.txt")))]
    r5 = {k: median(r.get(k) for r in register5) for k in register5[0]} if register5 else {}
    r20_path = os.path.join(out, "register20_1.txt")
    r20 = key_values(r20_path) if os.path.exists(r20_path) else {}
    seq = run_mode(out, "sequential", repeat)
    pipe = run_mode(out, "pipelined", repeat)
    sim = simulate(out)
    same = read(os.path.join(out, "run_trajectories_identical.txt")).strip() == "same"
    frontend = by_name.get("BM_FrontendPerFrame", {})
    summary = {
        "machine": machine(out), "repetitions": repeat, "quick": quick,
        "frontend_ms_per_frame": frontend.get("median_ms"),
        "frontend_cpu_ms_per_frame": frontend.get("cpu_ms"),
        "load_ms_per_frame": by_name.get("BM_LoadFrame", {}).get("median_ms"),
        "register_step5": r5, "register_step20": r20,
        "run_sequential": seq, "run_pipelined": pipe,
        "pipelined_over_sequential_wall": pipe["wall_s"] / seq["wall_s"],
        "pipelined_trajectory_identical": same,
        "simulate": sim, "scale": scale(out), "micro": micro,
        "localize": {name: localize(out, name) for name in ("7scenes", "rpy")},
        "continued": {name: continued(out, name) for name in ("7scenes", "rpy")},
    }
    with open(os.path.join(out, "bench.json"), "w") as f:
        json.dump(summary, f, indent=2)

    m = summary["machine"]
    lines = ["# ieslam benchmarks", "",
             "Machine: %s, %d cores, %.1f GB, Linux %s, OpenCV %s, commit %s. Load average %s "
             "before, %s after (2 cores: above 2 means other work was running). Medians of %d "
             "repetition(s)%s; the bench took %d s." % (
                 m["cpu"], m["cores"], m["memory_gb"], m["kernel"], m["opencv"], m["commit"],
                 fmt(m["load_1min_before"], 2), fmt(m["load_1min_after"], 2), repeat,
                 ", quick mode: `ieslam run` on the first 150 frames" if quick else "",
                 m["bench_seconds"]), "",
             "| measurement | value | target |", "|---|---|---|"]

    def row(name, value, target="", digits=3):
        lines.append("| %s | %s | %s |" % (name, fmt(value, digits), target))

    row("front end ms/frame, 1 thread (features + match previous + lift + RANSAC), wall",
        summary["frontend_ms_per_frame"], "≤ 40 (front end)", 1)
    row("front end ms/frame, 1 thread, CPU time", summary["frontend_cpu_ms_per_frame"], "", 1)
    row("load + decode ms/frame (JPEG + 16-bit PNG + depth to metres)",
        summary["load_ms_per_frame"], "", 1)
    row("register --step 5: success", r5.get("register.success_rate"), "≥ 0.98")
    row("register --step 5: median rotation error (deg)", r5.get("register.rot_err_median_deg"), "≤ 0.3")
    row("register --step 5: median translation error (cm)",
        r5["register.trans_err_median_m"] * 100 if r5 else None, "≤ 0.8")
    row("register --step 5: ms_per_frame (1 OpenCV thread)", r5.get("register.ms_per_frame"), "≤ 40", 1)
    row("register --step 20: success", r20.get("register.success_rate"), "≥ 0.90")
    for name, mode, rtf_target in (("run --threads 1", seq, "≥ 1.0"),
                                   ("run, pipelined (default threads)", pipe, "≥ 3.0")):
        row("%s: wall s (%d frames = %.1f s of data)" % (name, mode["frames"], mode["frames"] / FPS),
            mode["wall_s"], "", 1)
        row("%s: real-time factor" % name, mode["realtime_factor"],
            rtf_target + ("" if quick else " (7scenes-dev)"), 2)
        s = mode["seconds"]
        row("%s: seconds frontend / selection / filter / load" % name,
            "%.1f / %.1f / %.1f / %.1f" % (s["frontend"], s["selection"], s["filter"], s["load"]))
        row("%s: estimator real-time factor (selection + filter)" % name,
            mode["estimator_realtime_factor"], "≥ 10", 1)
        row("%s: peak RSS (MB)" % name, mode["peak_rss_mb"], "≤ 1536", 0)
        ate = mode["ate_rmse_m"] or {}
        row("%s: frames selected, ATE keyframes / all frames (cm)" % name,
            "%d, %.2f / %.2f" % (mode["frames_selected"], 100 * ate.get("keyframes", float("nan")),
                                 100 * ate.get("trajectory", float("nan"))))
    row("run, pipelined: state dimension", pipe["state_dim"], "" if quick else "≤ 4970 (7scenes-dev)")
    row("pipelined / sequential wall time", summary["pipelined_over_sequential_wall"], "", 2)
    row("pipelined trajectory.tum identical to --threads 1", "yes" if same else "NO", "yes")
    row("simulate: info (buffer 3) / all-frames time", sim["time_ratio"], "paper ≈ 0.5", 2)
    row("simulate: info (buffer 3) / all-frames state dimension", sim["dim_ratio"], "paper ≈ 0.67", 2)
    row("simulate: frames used by info (buffer 3)", "%.0f of %.0f" % (sim["frames_used_info3"],
                                                                    sim["frames_total"]),
        "paper 163 of 300")
    labels = {"7scenes": "7scenes-dev (map 0-249, localise 250-499)",
              "rpy": "tum-fr1-rpy-300 (map 0-149, localise 150-299)"}
    for name, label in labels.items():
        loc = summary["localize"].get(name)
        if loc is None:
            continue
        row("localize %s: share localised (by the map)" % label, "%.3f (%.3f)" % (
            loc["localized_share"], loc["localized_by_map_share"]), "≥ 0.95")
        row("localize %s: ATE in the map frame / aligned (cm)" % label, "%.2f / %.2f" % (
            100 * loc["ate_map_frame_m"], 100 * loc["ate_aligned_m"]), "≤ 3.5")
        row("localize %s: real-time factor (%d frames, wall %.1f s)" % (
            label, loc["frames"], loc["wall_s"]), loc["realtime_factor"], "≥ 3.0", 2)
        row("localize %s: map load s (%d keyframes)" % (label, loc["map_keyframes"]),
            loc["load_map_s"], "≤ 1", 3)
        con = summary["continued"].get(name)
        if con is not None:
            row("run --map %s: keyframe ATE (cm), %d keyframes (%d from the map) / one run, %d"
                % (label.replace("localise", "map on"), con["keyframes"], con["map_keyframes"],
                   con["single_keyframes"]),
                "%.2f / %.2f" % (100 * con["ate_keyframes_m"], 100 * con["single_ate_keyframes_m"]),
                "≤ one run")
            row("run --map %s: map load s" % label.replace("localise", "map on"),
                con["load_map_s"], "≤ 1", 3)
    sc = summary["scale"]
    if sc:
        lines += ["", "Scale (one run each, `ieslam run` wall time from /usr/bin/time -v; real-time "
                  "factor = frames / 30 Hz / wall):", "",
                  "| measurement | value | target |", "|---|---|---|"]
        labels = {"rpy": "tum-fr1-rpy-300", "rpy_threads1": "tum-fr1-rpy-300 --threads 1",
                  "synth600": "synth 600 frames", "synth2000": "synth 2,000 frames",
                  "synth2000_threads1": "synth 2,000 frames --threads 1"}
        rtf_targets = {"rpy": "≥ 2.0", "rpy_threads1": "≥ 1.0", "synth2000": "≥ 2.0",
                       "synth2000_threads1": "≥ 1.0"}
        for name, label in labels.items():
            r = sc["runs"].get(name)
            if r is None:
                continue
            s_ = r["seconds"]
            row("%s: real-time factor (%d frames, %d keyframes, wall %.1f s)" % (
                label, r["frames"], r["keyframes"], r["wall_s"]), r["realtime_factor"],
                rtf_targets.get(name, ""), 2)
            row("%s: last / first quarter cost per frame" % label, r["last_to_first_quarter"],
                "≤ 1.2" if name in ("rpy", "synth2000") else "", 2)
            split = sc["last_quarter_split"].get(name)
            if split:
                row("%s: last quarter in the whole run / its frames run alone (the map's size)"
                    % label, split["map_size"], "", 2)
                row("%s: its frames run alone / the first quarter (the content)" % label,
                    split["content"], "", 2)
            row("%s: peak RSS (MiB)" % label, r["peak_rss_mib"],
                {"rpy": "≤ 250", "synth2000": "≤ 400"}.get(name, ""), 0)
            stages = ("registration", "selection", "filter", "map", "outputs", "other")
            row("%s: seconds %s (of total %.1f)" % (label, " / ".join(stages), s_["total"]),
                " / ".join("%.1f" % s_.get(k, 0.0) for k in stages))
        row("memory per non-keyframe, synth 600 → 2,000 frames (KB)", sc["kb_per_non_keyframe"],
            "≤ 100", 1)
        small, large = sc["runs"].get("rpy_refine"), sc["runs"].get("rpy_refine_interval1")
        for label, r, target in (("tum-fr1-rpy-300 --refine", small, "≤ 5"),
                                 ("tum-fr1-rpy-300 --selector interval --interval 1 --refine",
                                  large, "≤ 15")):
            if r is None:
                continue
            row("%s: seconds.ba (%d keyframes)" % (label, r["keyframes"]), r["seconds"].get("ba"),
                target, 1)
            row("%s: ATE refined (cm)" % label, 100 * r["ate_rmse_m"].get("refined", float("nan")),
                "", 2)
        if small and large and small["seconds"].get("ba") and large["seconds"].get("ba"):
            growth = (large["seconds"]["ba"] / large["keyframes"]) / (
                small["seconds"]["ba"] / small["keyframes"])
            row("refinement: seconds per keyframe, interval-1 problem / default problem", growth,
                "≤ 1 (at most linear)", 2)
        ex = sc["simulate_exact"]
        if ex:
            row("simulate, iterative_recovery 0: info (buffer 3) / all-frames time",
                ex["time_ratio"], "≤ 0.5", 2)
            row("simulate, iterative_recovery 0: info (buffer 3) / all-frames state dimension",
                ex["dim_ratio"], "≤ 0.67", 3)
    lines += ["", "| micro-benchmark | median ms (wall) | CPU ms | counters |", "|---|---|---|---|"]
    for r in micro:
        lines.append("| %s | %.3f | %.3f | %s |" % (r["what"], r["median_ms"], r["cpu_ms"], ", ".join(
            "%s=%g" % kv for kv in r["counters"].items() if isinstance(kv[1], (int, float)))))
    text = "\n".join(lines) + "\n"
    with open(os.path.join(out, "bench.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
