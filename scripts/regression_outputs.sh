#!/usr/bin/env bash
# Writes the outputs of a fixed set of `ieslam` commands, all in the deterministic
# single-thread mode, so that a behaviour-preserving change can be checked against the
# outputs of the commit before it with scripts/compare_outputs.py:
#
#   scripts/regression_outputs.sh OLD_BUILD/apps/ieslam /tmp/before
#   scripts/regression_outputs.sh build/apps/ieslam /tmp/after
#   scripts/compare_outputs.py /tmp/before /tmp/after
#
# The set covers every command and output: synth (both sensors), run with --refine on a
# synthetic dataset, 7scenes-dev and tum-fr1-rpy-300, the other selectors, refine (with
# depth alignment and from the ground truth), simulate, register and evaluate.
# Usage: scripts/regression_outputs.sh IESLAM OUT [--quick]   (--quick: short sequences only)
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n '2,13p' "$0" >&2
  exit 2
fi
ieslam=$(realpath "$1")
mkdir -p "$2"
out=$(realpath "$2")
quick=${3:-}
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
data=$(realpath "$root/../shared/data")
# The source tree the binary was built from (its calibration files are named in reports): the
# comparison masks it, so that trees from two checkouts compare.
cache=$(dirname "$ieslam")/../CMakeCache.txt
sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$cache" > "$out/source_root" 2>/dev/null || true
log=$out/commands.log
: > "$log"

# Runs one command, its stdout saved as OUT/<name>.stdout; a failure is recorded, not fatal,
# so that the comparison sees it (exit codes are compared too).
step() {
  local name=$1
  shift
  echo "== $name" >&2
  set +e
  "$ieslam" "$@" > "$out/$name.stdout" 2> "$out/$name.stderr"
  echo $? > "$out/$name.exit"
  set -e
  echo "$name: ieslam $*" >> "$log"
}

step synth_rgbd synth --output "$out/synth_rgbd" --frames 90 --seed 3 --threads 1
step synth_pair synth --output "$out/synth_pair" --frames 40 --seed 2 --sensor pair --threads 1
step run_synth run --dataset "$out/synth_rgbd" --output "$out/run_synth" --threads 1 --refine --quiet
step run_pair run --dataset "$out/synth_pair" --output "$out/run_pair" --threads 1 --refine --quiet
step run_synth_all run --dataset "$out/synth_rgbd" --output "$out/run_synth_all" --threads 1 \
  --selector all --quiet
step run_synth_interval run --dataset "$out/synth_rgbd" --output "$out/run_synth_interval" \
  --threads 1 --selector interval --interval 4 --quiet
step run_synth_dr run --dataset "$out/synth_rgbd" --output "$out/run_synth_dr" --threads 1 \
  --selector deadreckoning --quiet
step run_desk9 run --dataset "$data/tum-fr1-desk-9" --output "$out/run_desk9" --threads 1 --quiet
step simulate simulate --output "$out/simulate" --runs 2 --buffers 3,4 --seed 2 --quiet
step simulate_rect simulate --output "$out/simulate_rect" --runs 1 --buffers 2 \
  --trajectory rectangle --quiet
step register_desk9 register --dataset "$data/tum-fr1-desk-9" --step 2 --output "$out/register_desk9" --quiet
step evaluate_tum evaluate --gt "$data/tum-eval/fr2_desk_groundtruth.txt" \
  --est "$data/tum-eval/fr2_desk_ORB.txt" --output "$out/evaluate_tum"
step refine_synth refine --run "$out/run_synth" --output "$out/refine_synth" \
  --dataset "$out/synth_rgbd" --threads 1
step refine_synth_gt refine --run "$out/run_synth" --output "$out/refine_synth_gt" \
  --from-ground-truth --robust huber --threads 1
if [ "$quick" != --quick ]; then
  step run_7scenes run --dataset "$data/7scenes-dev" --output "$out/run_7scenes" --threads 1 \
    --refine --quiet
  step run_rpy run --dataset "$data/tum-fr1-rpy-300" --output "$out/run_rpy" --threads 1 \
    --refine --quiet
  step run_7scenes_all run --dataset "$data/7scenes-dev" --output "$out/run_7scenes_all" \
    --threads 1 --selector all --last 199 --quiet
  step register_7scenes register --dataset "$data/7scenes-dev" --step 5 --last 99 \
    --output "$out/register_7scenes" --quiet
  step evaluate_7scenes evaluate --gt "$out/run_7scenes/groundtruth.tum" \
    --est "$out/run_7scenes/trajectory.tum" --delta 5 --delta-unit f --output "$out/evaluate_7scenes"
fi
echo "regression_outputs: $out" >&2
