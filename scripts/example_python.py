#!/usr/bin/python3
"""The Python module on a dataset: a run, its ATE per frame against the ground truth, a plot.

Usage: PYTHONPATH=build/python scripts/example_python.py OUT [DATASET]
       (default DATASET: the first 100 frames of ../shared/data/7scenes-dev)

Writes OUT/ate_per_frame.png and the run's files (as `ieslam run --output OUT/run`), and prints
the ATE figures. Runs with Debian's /usr/bin/python3 (python3-numpy, python3-matplotlib).
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import ieslam  # noqa: E402

if len(sys.argv) not in (2, 3):
    sys.exit(__doc__.strip())
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
out = sys.argv[1]
dataset = sys.argv[2] if len(sys.argv) > 2 else os.path.join(root, "..", "shared", "data",
                                                             "7scenes-dev")
overrides = {} if len(sys.argv) > 2 else {"last": 99}

# The deterministic mode: the same trajectory as `ieslam run --threads 1 --seed 1`.
result = ieslam.run(dataset, {"selector": {"buffer": 3}}, threads=1, seed=1, **overrides)
result.write(os.path.join(out, "run"))
print(f"{len(result.trajectory)} frames, {len(result.keyframes)} keyframes "
      f"(frames {result.keyframe_ids[:8]}...), {result.seconds['total']:.1f} s")

# As `ieslam evaluate --gt groundtruth.tum --est trajectory.tum` on the written files.
evaluation = ieslam.evaluate(os.path.join(out, "run", "groundtruth.tum"),
                             os.path.join(out, "run", "trajectory.tum"))
print(evaluation["text"], end="")

pairs = evaluation["ate_pairs"]  # gt timestamp, est timestamp, error (m) per frame
t0 = pairs[0, 0]
# The files' stamps have 6 decimals.
is_keyframe = np.isin(np.round(pairs[:, 1], 6), np.round(result.keyframes[:, 0], 6))
fig, ax = plt.subplots(figsize=(8, 3.5))
ax.plot(pairs[:, 0] - t0, pairs[:, 2] * 100.0, lw=1, label="every frame")
ax.plot(pairs[is_keyframe, 0] - t0, pairs[is_keyframe, 2] * 100.0, "o", ms=4,
        label="keyframes (selected)")
ax.axhline(evaluation["ate"]["rmse"] * 100.0, color="grey", ls="--",
           label=f"RMSE {evaluation['ate']['rmse'] * 100:.2f} cm")
ax.set_xlabel("time (s)")
ax.set_ylabel("ATE (cm)")
ax.set_title(f"ATE per frame, {os.path.basename(os.path.normpath(dataset))}")
ax.legend()
fig.tight_layout()
png = os.path.join(out, "ate_per_frame.png")
fig.savefig(png, dpi=120)
print(f"plot: {png}")
