#!/usr/bin/env bash
# The README's first command: installs what is missing, builds Release, and runs ieslam on its
# embedded default — a synthetic RGB-D scene it renders itself, with exact ground truth —
# then the paper's simulation, writing results and plots to OUT (default: demo_output/).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-$root/demo_output}
build_dir=${BUILD_DIR:-$root/build}
frames=${DEMO_FRAMES:-120}

"$root/scripts/install_deps.sh"
BUILD_DIR=$build_dir "$root/scripts/build.sh"
ieslam=$build_dir/apps/ieslam
mkdir -p "$out"

echo "== 1/4 synthesise a ${frames}-frame RGB-D sequence of a textured room (exact ground truth)"
"$ieslam" synth --output "$out/synthetic" --frames "$frames" --seed 1
echo "== 2/4 run the pipeline on it (info selector)"
"$ieslam" run --dataset "$out/synthetic" --output "$out/run" --threads 1
echo "== 3/4 the paper's simulation (Table I, one Monte-Carlo run, buffer 3)"
"$ieslam" simulate --output "$out/simulate" --runs 1 --buffers 3 --seed 1
echo "== 4/4 plots"
/usr/bin/python3 "$root/scripts/plot.py" "$out/run"
/usr/bin/python3 "$root/scripts/plot.py" "$out/simulate"
"$ieslam" evaluate --gt "$out/run/groundtruth.tum" --est "$out/run/trajectory.tum" --output "$out/run"

echo
echo "ieslam demo: results in $out"
echo "  $out/run/report.json, trajectory.tum, keyframes.tum, map.ply, plots/*.png"
echo "  $out/simulate/table.md, report.json, plots/table.png"
