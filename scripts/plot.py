#!/usr/bin/python3
"""Plots of an `ieslam run` or `ieslam simulate` output directory, written to OUT/plots/.

Usage: scripts/plot.py OUT

run:       trajectory_top.png    top view of the trajectory against ground truth, coloured by
                                 error after Horn alignment (as the ATE is computed)
           selected_frames.png   which frames the selector added over the sequence (paper Fig. 7)
           information_sparsity.png  nonzero blocks of the final information matrix (Fig. 8)
           keyframe_sigma.png    final position / heading uncertainty of every keyframe over the
                                 sequence, selected frames marked (Fig. 12)
           keyframe_errors.png   per-axis keyframe error against ground truth (same origin as the
                                 estimate) with its +-2 sigma, filter and refined (Figs. 3-4)
           eif_minus_ba.png      with --refine: per-keyframe filter - bundle adjustment difference
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
            # The report has only the ATEs it could compute (3 or more poses each).
            ate = report.get("ate_rmse_m", {})
            ax.set_title("ATE RMSE %s (all frames), %s (keyframes)" % tuple(
                "%.2f cm" % (100 * ate[key]) if key in ate else "n/a"
                for key in ("trajectory", "keyframes")))
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
    # selected_frames.txt has dataset indices: the processed frames are first, first + stride, ...
    dataset = report.get("options", {}).get("dataset", {})
    first, stride = dataset.get("first", 0), dataset.get("stride", 1)
    ax.set_xlim(first, first + max(total - 1, 1) * stride)
    ax.set_yticks([])
    ax.set_xlabel("frame")
    ax.set_title("%d of %d frames selected (%s selector)" % (
        len(selected), total, report["options"]["selector"]["kind"]))
    save(fig, out, "selected_frames.png")
    plot_information(out)
    plot_keyframe_uncertainty(out, report)
    plot_eif_minus_ba(out, report)


def plot_information(out):
    path = os.path.join(out, "information_blocks.txt")
    if not os.path.exists(path):
        return
    kinds, pairs = "", []
    with open(path) as f:
        for line in f:
            if line.startswith("blocks "):
                kinds = line.split()[1]
            elif line.strip() and not line.startswith("#"):
                pairs.append([int(v) for v in line.split()])
    n = len(kinds)
    pairs = np.array(pairs, dtype=int).reshape(-1, 2)
    poses = np.array([k for k, c in enumerate(kinds) if c == "P"])
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    ms = max(0.05, min(2.0, 300.0 / max(n, 1)))
    ax.plot(pairs[:, 1], pairs[:, 0], ",", ms=ms, color="C0")
    ax.plot(pairs[:, 0], pairs[:, 1], ",", ms=ms, color="C0")
    ax.plot(np.arange(n), np.arange(n), ",", color="C0")
    ax.plot(poses, poses, "s", ms=2, color="red", label="pose blocks")
    ax.set_xlim(0, n)
    ax.set_ylim(n, 0)
    ax.set_aspect("equal")
    ax.set_xlabel("state block (poses and features, in the order added)")
    ax.legend(loc="upper right", fontsize=8)
    fill = (2 * len(pairs) + n) / float(max(n, 1) ** 2) * 100
    ax.set_title("Final information matrix: %d blocks (%d poses), %.2f%% of blocks nonzero" % (
        n, len(poses), fill))
    save(fig, out, "information_sparsity.png")


def plot_keyframe_uncertainty(out, report):
    sigmas = report.get("keyframe_sigmas", [])
    if not sigmas:
        return
    frames = np.array([s["frame"] for s in sigmas])
    stamps = np.array([s["timestamp"] for s in sigmas])
    sig = np.array([s["sigma"] for s in sigmas])
    fig, ax = plt.subplots(2, 1, figsize=(9, 4.5), sharex=True)
    ax[0].plot(frames, 100 * np.linalg.norm(sig[:, :3], axis=1), ".-", lw=0.8)
    ax[0].set_ylabel("position σ (cm)")
    ax[1].plot(frames, np.degrees(np.linalg.norm(sig[:, 3:], axis=1)), ".-", lw=0.8, color="C1")
    ax[1].set_ylabel("orientation σ (deg)")
    for a in ax:
        a.vlines(frames, 0, 0.04, transform=a.get_xaxis_transform(), lw=0.6, color="k")
    ax[1].set_xlabel("frame (ticks: selected frames)")
    fig.suptitle("Final uncertainty of each keyframe (paper Fig. 12)")
    save(fig, out, "keyframe_sigma.png")

    plot_keyframe_errors(out, report.get("consistency", {}))


def plot_keyframe_errors(out, consistency):
    """Per-axis keyframe error against ground truth with the estimator's own +-2 sigma, for the
    filter and, with --refine, the bundle adjustment (the report's consistency section: same
    origin as the estimate, no alignment fitted)."""
    rows = [(name, consistency[name]) for name in ("filter", "refined") if name in consistency]
    if not rows:
        return
    names = ["x (m)", "y (m)", "z (m)", "alpha (rad)", "beta (rad)", "gamma (rad)"]
    fig, axes = plt.subplots(6, len(rows), figsize=(6 * len(rows), 10), sharex=True, squeeze=False)
    for col, (name, c) in enumerate(rows):
        per = c["per_keyframe"]
        at = np.array([p["frame"] for p in per])
        err = np.array([p["error"] for p in per])
        bound = 2 * np.array([p["sigma"] for p in per])
        for k in range(6):
            a = axes[k, col]
            a.plot(at, err[:, k], lw=0.8, label="error")
            a.plot(at, bound[:, k], "r--", lw=0.6, label="±2σ")
            a.plot(at, -bound[:, k], "r--", lw=0.6)
            if col == 0:
                a.set_ylabel(names[k], fontsize=8)
        axes[0, col].set_title("%s: %.0f%% of positions inside ±2σ, mean NEES %.1f (band %.1f-%.1f)"
                               % (name, 100 * c["inside_2sigma"], c["mean_nees"],
                                  c["nees_band"][0], c["nees_band"][1]), fontsize=9)
        axes[-1, col].set_xlabel("frame")
    axes[0, 0].legend(loc="upper right", fontsize=8)
    fig.suptitle("Keyframe errors against ground truth with the stated ±2σ (paper Figs. 3-4)")
    save(fig, out, "keyframe_errors.png")


def plot_eif_minus_ba(out, report):
    frames = report.get("filter_vs_smoother", {}).get("frames", [])
    if not frames:
        return
    ids = np.array([f["frame_id"] for f in frames])
    fig, ax = plt.subplots(3, 1, figsize=(9, 6), sharex=True)
    ax[0].plot(ids, [100 * f["translation_m"] for f in frames], ".-", lw=0.8)
    ax[0].set_ylabel("|Δt| (cm)")
    ax[1].plot(ids, [f["rotation_deg"] for f in frames], ".-", lw=0.8, color="C1")
    ax[1].set_ylabel("Δ rotation (deg)")
    ax[2].plot(ids, [f["mahalanobis"] for f in frames], ".-", lw=0.8, color="C2")
    ax[2].set_ylabel("Mahalanobis")
    ax[2].set_xlabel("frame")
    fs = report["filter_vs_smoother"]
    fig.suptitle("Filter − bundle adjustment per keyframe: RMS %.2f cm, %.2f°" % (
        100 * fs["translation_m"]["rmse"], fs["rotation_deg"]["rmse"]))
    save(fig, out, "eif_minus_ba.png")


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
