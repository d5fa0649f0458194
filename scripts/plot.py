#!/usr/bin/python3
"""Plots of an `ieslam run` or `ieslam simulate` output directory, written to OUT/plots/.

Usage: scripts/plot.py OUT

run:       trajectory_top.png    top view of the trajectory against ground truth, coloured by
                                 error after Horn alignment (as the ATE is computed)
           selected_frames.png   which frames the selector added over the sequence (paper Fig. 7)
simulate:  table.png             frames used, time and state dimension per selector (Table I)
Runs with Debian's /usr/bin/python3 and python3-matplotlib (scripts/install_deps.sh installs it).
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_tum(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#"):
                rows.append([float(v) for v in line.replace(",", " ").split()[:8]])
    return np.array(rows).reshape(-1, 8)


def associate(a, b, max_diff=0.02):
    """Nearest-timestamp pairs as TUM's associate.py (greedy on |dt|)."""
    candidates = sorted(
        (abs(ta - tb), i, j)
        for i, ta in enumerate(a[:, 0])
        for j, tb in enumerate(b[:, 0])
        if abs(ta - tb) < max_diff
    ) if len(a) * len(b) < 4_000_000 else []
    used_a, used_b, pairs = set(), set(), []
    for _, i, j in candidates:
        if i not in used_a and j not in used_b:
            used_a.add(i)
            used_b.add(j)
            pairs.append((i, j))
    return sorted(pairs)


def horn(est, gt):
    """Rotation R and translation t minimising |gt - (R est + t)| (no scale)."""
    mu_e, mu_g = est.mean(0), gt.mean(0)
    u, _, vt = np.linalg.svd((gt - mu_g).T @ (est - mu_e))
    s = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        s[2, 2] = -1
    r = u @ s @ vt
    return r, mu_g - r @ mu_e


def save(fig, out, name):
    os.makedirs(os.path.join(out, "plots"), exist_ok=True)
    path = os.path.join(out, "plots", name)
    fig.savefig(path + ".tmp.png", dpi=120, bbox_inches="tight")
    os.replace(path + ".tmp.png", path)
    plt.close(fig)
    print("plot:", path)


def plot_run(out, report):
    traj = read_tum(os.path.join(out, "trajectory.tum"))
    keys = read_tum(os.path.join(out, "keyframes.tum"))
    gt_path = os.path.join(out, "groundtruth.tum")
    fig, ax = plt.subplots(figsize=(7, 6))
    if os.path.exists(gt_path):
        gt = read_tum(gt_path)
        pairs = associate(traj, gt)
        if len(pairs) >= 3:
            i, j = np.array(pairs).T
            r, t = horn(traj[i, 1:4], gt[j, 1:4])
            aligned = traj[:, 1:4] @ r.T + t
            err = np.linalg.norm(aligned[i] - gt[j, 1:4], axis=1)
            ax.plot(gt[:, 1], gt[:, 2], color="0.6", lw=1, label="ground truth")
            sc = ax.scatter(aligned[i, 0], aligned[i, 1], c=err * 100, s=6, cmap="viridis")
            fig.colorbar(sc, ax=ax, label="position error (cm)")
            ka = keys[:, 1:4] @ r.T + t
            ax.scatter(ka[:, 0], ka[:, 1], marker="x", s=14, color="red", label="keyframes")
            ax.set_title("ATE RMSE %.2f cm (all frames), %.2f cm (keyframes)" % (
                100 * report["ate_rmse_m"]["trajectory"], 100 * report["ate_rmse_m"]["keyframes"]))
    else:
        ax.plot(traj[:, 1], traj[:, 2], lw=1, label="estimate")
        ax.scatter(keys[:, 1], keys[:, 2], marker="x", s=14, color="red", label="keyframes")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.axis("equal")
    ax.legend(loc="best")
    save(fig, out, "trajectory_top.png")

    selected = np.loadtxt(os.path.join(out, "selected_frames.txt"), ndmin=2)[:, 0]
    total = report["frames_total"]
    fig, ax = plt.subplots(figsize=(9, 2.4))
    ax.vlines(selected, 0, 1, lw=0.8)
    ax.set_xlim(0, max(total, 1))
    ax.set_yticks([])
    ax.set_xlabel("frame")
    ax.set_title("%d of %d frames selected (%s selector)" % (
        len(selected), total, report["options"]["selector"]["kind"]))
    save(fig, out, "selected_frames.png")


def plot_simulate(out, report):
    rows = report["table"]
    labels = ["%s%s" % (r["selector"], "" if r["selector"] == "all" else " b=%d" % r["buffer"]) for r in rows]
    fig, axes = plt.subplots(1, 3, figsize=(11, 3))
    for ax, key, title in zip(axes, ["frames_used", "seconds", "state_dim"],
                              ["frames used", "time (s)", "state dimension"]):
        ax.bar(labels, [r[key] for r in rows], color=["0.5"] + ["C0"] * (len(rows) - 1))
        ax.set_title(title)
        ax.tick_params(axis="x", rotation=45)
    fig.suptitle("Paper's Table I: all-frames EIF vs information-efficient selection")
    save(fig, out, "table.png")

    # Per-axis pose errors with +-2 sigma bounds (paper Figs. 3-4), first run of each row.
    axes_names = ["x (m)", "y (m)", "z (m)", "alpha (rad)", "beta (rad)", "gamma (rad)"]
    for row in report.get("first_run_pose_errors", []):
        poses = row["poses"]
        frames = np.array([p["frame"] for p in poses])
        err = np.array([p["error"] for p in poses])
        sig = np.array([p["sigma"] for p in poses])
        fig, axes = plt.subplots(6, 1, figsize=(9, 10), sharex=True)
        for k, ax in enumerate(axes):
            ax.plot(frames, err[:, k], lw=0.8, label="error")
            ax.plot(frames, 2 * sig[:, k], "r--", lw=0.6, label="±2σ")
            ax.plot(frames, -2 * sig[:, k], "r--", lw=0.6)
            ax.set_ylabel(axes_names[k], fontsize=8)
        axes[0].legend(loc="upper right", fontsize=8)
        axes[-1].set_xlabel("frame")
        name = row["selector"] if row["selector"] == "all" else "info_b%d" % row["buffer"]
        inside = np.mean(np.abs(err) <= 2 * sig) * 100
        fig.suptitle("Pose errors with ±2σ bounds, %s: %.1f%% inside" % (name, inside))
        save(fig, out, "pose_errors_%s.png" % name)


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    out = sys.argv[1]
    with open(os.path.join(out, "report.json")) as f:
        report = json.load(f)
    if "table" in report:
        plot_simulate(out, report)
    else:
        plot_run(out, report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
