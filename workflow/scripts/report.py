#!/usr/bin/python3
"""The benchmark report: RESULTS.md, results.csv, results.tex and plots/ from the runs' CSV.

    report.py --runs RUNS.csv --output DIR [--simulate MERGED/report.json] [--peers JSON]
              [--repo DIR]

Groups the runs by (dataset, selector, buffer) and gives the mean and standard deviation
over the seeds of the runs that worked; the runs that failed get a table of their own, with
their log's tail. Only matplotlib and the standard library.
"""
import argparse
import csv
import json
import math
import os
import platform
import subprocess
from datetime import datetime, timezone

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# (column, heading, format): the per-group metrics, in the tables' order.
METRICS = [
    ("frames_total", "frames", "{:.0f}"),
    ("frames_selected", "keyframes", "{:.1f}"),
    ("ate_filter_m", "ATE filter (m)", "{:.4f}"),
    ("ate_refined_m", "ATE refined (m)", "{:.4f}"),
    ("rpe_trans_filter_m", "RPE filter (m)", "{:.4f}"),
    ("rpe_rot_filter_deg", "RPE filter (°)", "{:.3f}"),
    ("rpe_trans_refined_m", "RPE refined (m)", "{:.4f}"),
    ("inside_2sigma_filter", "inside 2σ filter", "{:.2f}"),
    ("mean_nees_filter", "NEES filter", "{:.1f}"),
    ("inside_2sigma_refined", "inside 2σ refined", "{:.2f}"),
    ("mean_nees_refined", "NEES refined", "{:.1f}"),
    ("rtf", "real-time factor", "{:.2f}"),
    ("peak_mem_mb", "peak memory (MB)", "{:.0f}"),
]
STAGES = ["frontend_s", "selection_s", "filter_s", "ba_s"]


def number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def mean_std(values):
    values = [v for v in values if v is not None and not math.isnan(v)]
    if not values:
        return None, None
    mean = sum(values) / len(values)
    if len(values) < 2:
        return mean, 0.0
    return mean, math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1))


def label(selector, buffer):
    return f"{selector} (buffer {buffer})" if selector == "info" else selector


def groups_of(runs):
    groups = {}
    for run in runs:
        key = (run["dataset"], run["selector"], int(run["buffer"]))
        groups.setdefault(key, []).append(run)
    out = []
    for (dataset, selector, buffer), members in sorted(groups.items()):
        ok = [r for r in members if r["ok"] == "1"]
        group = {"dataset": dataset, "selector": selector, "buffer": buffer,
                 "seeds": len(members), "ok": len(ok)}
        for column in [m[0] for m in METRICS] + STAGES:
            group[column] = mean_std([number(r[column]) for r in ok])
        out.append(group)
    return out


def cell(value, fmt, plus_minus="±"):
    mean, std = value
    if mean is None:
        return "–"
    return fmt.format(mean) + (f" {plus_minus} " + fmt.format(std) if std else "")


def machine():
    cpu = platform.processor() or "?"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{os.cpu_count()} cores (nproc), {cpu}, {platform.system()} {platform.release()}"


def commit(repo):
    try:
        return subprocess.run(["git", "-C", repo, "rev-parse", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def write_csv(path, groups):
    columns = ["dataset", "selector", "buffer", "seeds", "ok"]
    for name in [m[0] for m in METRICS] + STAGES:
        columns += [name + "_mean", name + "_std"]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(columns)
        for g in groups:
            row = [g["dataset"], g["selector"], g["buffer"], g["seeds"], g["ok"]]
            for name in [m[0] for m in METRICS] + STAGES:
                row += ["" if v is None else repr(v) for v in g[name]]
            writer.writerow(row)


def write_tex(path, groups):
    shown = [m for m in METRICS if m[0] in ("frames_selected", "ate_filter_m", "ate_refined_m",
                                            "rpe_trans_filter_m", "mean_nees_filter", "rtf")]
    lines = ["% ieslam benchmark: mean $\\pm$ std over the seeds (booktabs)",
             "\\begin{tabular}{ll" + "r" * len(shown) + "}", "\\toprule",
             "sequence & selector & " + " & ".join(
                 h.replace("°", "$^\\circ$").replace("σ", "$\\sigma$") for _, h, _ in shown)
             + " \\\\", "\\midrule"]
    for g in groups:
        cells = [cell(g[c], f, "$\\pm$") for c, _, f in shown]
        name = label(g["selector"], g["buffer"])
        dataset = g["dataset"].replace("_", "\\_")
        lines.append(f"{dataset} & {name} & " + " & ".join(cells) + " \\\\")
    lines += ["\\bottomrule", "\\end{tabular}", ""]
    open(path, "w").write("\n".join(lines))


def bar_plot(path, groups, column, ylabel, title):
    datasets = sorted({g["dataset"] for g in groups})
    selectors = sorted({label(g["selector"], g["buffer"]) for g in groups})
    width = 0.8 / max(1, len(selectors))
    fig, ax = plt.subplots(figsize=(max(5, 1.8 * len(datasets)), 3.5))
    for k, sel in enumerate(selectors):
        xs, ys, es = [], [], []
        for i, ds in enumerate(datasets):
            for g in groups:
                if g["dataset"] == ds and label(g["selector"], g["buffer"]) == sel:
                    if g[column][0] is not None:
                        xs.append(i + k * width)
                        ys.append(g[column][0])
                        es.append(g[column][1] or 0.0)
        ax.bar(xs, ys, width, yerr=es, label=sel, capsize=2)
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(datasets))])
    ax.set_xticklabels(datasets)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plots(directory, groups, runs, simulate):
    os.makedirs(directory, exist_ok=True)
    made = []
    bar_plot(os.path.join(directory, "ate.png"), groups, "ate_filter_m", "ATE RMSE (m)",
             "ATE of the filter per sequence and selector (mean ± std over seeds)")
    made.append(("ATE per sequence and selector", "ate.png"))
    bar_plot(os.path.join(directory, "keyframes.png"), groups, "frames_selected", "keyframes",
             "Keyframes per sequence")
    made.append(("keyframes per sequence", "keyframes.png"))
    pairs = [(number(r["ate_filter_m"]), number(r["ate_refined_m"])) for r in runs if r["ok"] == "1"]
    pairs = [p for p in pairs if p[0] is not None and p[1] is not None]
    if pairs:
        fig, ax = plt.subplots(figsize=(4, 4))
        ax.scatter([p[0] for p in pairs], [p[1] for p in pairs], s=12)
        top = max(max(p) for p in pairs) * 1.1
        ax.plot([0, top], [0, top], "k--", lw=0.8)
        ax.set_xlabel("ATE filter (m)")
        ax.set_ylabel("ATE refined (m)")
        ax.set_title("Filter against refinement, every run")
        fig.tight_layout()
        fig.savefig(os.path.join(directory, "filter_vs_refined.png"), dpi=110)
        plt.close(fig)
        made.append(("filter against refinement", "filter_vs_refined.png"))
    fig, ax = plt.subplots(figsize=(max(5, 0.6 * len(groups)), 3.5))
    bottom = [0.0] * len(groups)
    for stage in STAGES:
        values = [g[stage][0] or 0.0 for g in groups]
        ax.bar(range(len(groups)), values, bottom=bottom, label=stage[:-2])
        bottom = [b + v for b, v in zip(bottom, values)]
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([f"{g['dataset']}\n{label(g['selector'], g['buffer'])}" for g in groups],
                       rotation=60, fontsize=6)
    ax.set_ylabel("seconds")
    ax.set_title("Time per stage (report.json seconds)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(directory, "time_per_stage.png"), dpi=110)
    plt.close(fig)
    made.append(("time per stage", "time_per_stage.png"))
    if simulate:
        table = simulate.get("table", [])
        fig, ax = plt.subplots(figsize=(5, 3.5))
        xs = range(len(table))
        ax.scatter(xs, [r["mean_nees"] for r in table], label="mean NEES", zorder=3)
        for x, r in zip(xs, table):
            ax.plot([x, x], r["nees_band"], "k-", lw=3, alpha=0.3)
        ax.axhline(6.0, color="grey", lw=0.8, ls="--")
        ax.set_xticks(list(xs))
        ax.set_xticklabels([label(r["selector"], r["buffer"]) for r in table], fontsize=7)
        ax.set_ylabel("mean NEES (6 dof)")
        ax.set_title(f"Simulation: NEES and its 95% band over {simulate.get('runs')} runs")
        fig.tight_layout()
        fig.savefig(os.path.join(directory, "nees.png"), dpi=110)
        plt.close(fig)
        made.append(("NEES with its band (simulation)", "nees.png"))
    return made


def markdown(groups, runs, simulate, simulate_table, peers, repo, made, plot_dir):
    out = ["# ieslam benchmark results", "",
           f"Made {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')} on {machine()}, "
           f"commit `{commit(repo)}`.", "",
           f"{len(runs)} runs, {sum(r['ok'] == '1' for r in runs)} of them ok. Cells are the "
           "mean ± standard deviation over the seeds of the runs that worked; `frames` are the "
           "frames processed, `keyframes` those the selector gave the filter. ATE/RPE are "
           "`ieslam evaluate`'s (Horn alignment, RPE over 1 s); consistency is report.json's "
           "`consistency.filter` / `consistency.refined`; real-time factor = the sequence's "
           "duration over the run's wall time.", ""]
    heading = ["sequence", "selector", "runs ok"] + [h for _, h, _ in METRICS]
    out += ["| " + " | ".join(heading) + " |", "|" + "---|" * len(heading)]
    for g in groups:
        out.append("| " + " | ".join([g["dataset"], label(g["selector"], g["buffer"]),
                                      f"{g['ok']}/{g['seeds']}"]
                                     + [cell(g[c], f) for c, _, f in METRICS]) + " |")
    out.append("")
    failed = [r for r in runs if r["ok"] != "1"]
    out += ["## Failed runs", ""]
    if not failed:
        out += ["None.", ""]
    else:
        out += ["| sequence | selector | buffer | seed | failure | log tail |", "|---|---|---|---|---|---|"]
        for r in failed:
            tail = "<br>".join(line.replace("|", "\\|") for line in r["log_tail"].splitlines()[-5:])
            out.append(f"| {r['dataset']} | {r['selector']} | {r['buffer']} | {r['seed']} | "
                       f"{r['failure']} | `{tail}` |" if tail else
                       f"| {r['dataset']} | {r['selector']} | {r['buffer']} | {r['seed']} | "
                       f"{r['failure']} | |")
        out.append("")
    if peers:
        out += ["## Published numbers beside ours", "",
                "| sequence | method | ATE (m) | ours (best selector, filter / refined) | source |",
                "|---|---|---|---|---|"]
        for p in peers:
            ours = [g for g in groups if g["dataset"] == p["sequence"] and g["ate_filter_m"][0]]
            best = min(ours, key=lambda g: g["ate_filter_m"][0]) if ours else None
            mine = (f"{best['ate_filter_m'][0]:.4f} / "
                    + (f"{best['ate_refined_m'][0]:.4f}" if best["ate_refined_m"][0] else "–")
                    + f" ({label(best['selector'], best['buffer'])})") if best else "–"
            out.append(f"| {p['sequence']} | {p['method']} | {p['ate_rmse_m']:.3f} | {mine} | "
                       f"{p['source']} |")
        out.append("")
    if simulate_table:
        out += ["## Monte-Carlo simulation (merged shards)", "",
                simulate_table.split("\n", 2)[-1].strip(), ""]
    out += ["## Plots", ""]
    for title, name in made:
        out.append(f"![{title}]({plot_dir}/{name})")
    out.append("")
    return "\n".join(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", required=True)
    parser.add_argument("--output", required=True)
    parser.add_argument("--simulate", default="")
    parser.add_argument("--peers", default="[]")
    parser.add_argument("--repo", default=".")
    args = parser.parse_args()
    runs = list(csv.DictReader(open(args.runs)))
    groups = groups_of(runs)
    simulate = json.load(open(args.simulate)) if args.simulate else None
    simulate_table = ""
    if args.simulate:
        table_md = os.path.join(os.path.dirname(args.simulate), "table.md")
        simulate_table = open(table_md).read() if os.path.exists(table_md) else ""
    os.makedirs(args.output, exist_ok=True)
    made = plots(os.path.join(args.output, "plots"), groups, runs, simulate)
    write_csv(os.path.join(args.output, "results.csv"), groups)
    write_tex(os.path.join(args.output, "results.tex"), groups)
    page = markdown(groups, runs, simulate, simulate_table, json.loads(args.peers), args.repo,
                    made, "plots")
    open(os.path.join(args.output, "RESULTS.md"), "w").write(page)


if __name__ == "__main__":
    main()
