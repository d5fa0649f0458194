#!/usr/bin/env bash
# Benchmarks (not tests): Google Benchmark micro-benchmarks and end-to-end timings on the
# shared real data and the paper's simulation, written as one table (OUT/bench.md and
# OUT/bench.json) with the machine's description. Medians of repeated runs; this machine is
# shared and noisy, so compare ratios rather than absolute times.
#
# Usage: scripts/bench.sh [OUT]   (default: bench_output/). REPEAT=3 sets the end-to-end repeats.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-$root/bench_output}
build_dir=${BUILD_DIR:-$root/build}
repeat=${REPEAT:-3}
data=$root/../shared/data

"$root/scripts/install_deps.sh"
BUILD_DIR=$build_dir "$root/scripts/build.sh" -DIESLAM_BUILD_BENCHMARKS=ON
ieslam=$build_dir/apps/ieslam
mkdir -p "$out"

echo "== micro-benchmarks" >&2
"$build_dir/tests/bench/ieslam_bench" --benchmark_repetitions="$repeat" \
  --benchmark_report_aggregates_only=true --benchmark_format=json > "$out/micro.json"

echo "== end to end" >&2
: > "$out/e2e.txt"
for r in $(seq "$repeat"); do
  "$ieslam" register --dataset "$data/7scenes-dev" --step 5 --output "$out/register5" --quiet \
    | sed "s/^/run$r /" >> "$out/e2e.txt"
  /usr/bin/time -v "$ieslam" run --dataset "$data/7scenes-dev" --output "$out/run" --threads 1 \
    --quiet 2> "$out/run_time_$r.txt" > /dev/null
  cp "$out/run/report.json" "$out/run_report_$r.json"
  "$ieslam" simulate --output "$out/simulate" --runs 1 --buffers 3 --quiet > /dev/null
  cp "$out/simulate/report.json" "$out/simulate_report_$r.json"
done

/usr/bin/python3 "$root/scripts/bench_table.py" "$out" "$repeat"
