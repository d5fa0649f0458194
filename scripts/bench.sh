#!/usr/bin/env bash
# Benchmarks (not tests): Google Benchmark micro-benchmarks and end-to-end timings on the
# shared real data and the paper's simulation, written as one table (OUT/bench.md and
# OUT/bench.json) with the machine's description. Medians of repeated runs; this machine is
# shared and noisy, so compare ratios rather than absolute times.
#
# Usage: scripts/bench.sh [--quick] [OUT]      (default OUT: bench_output/)
#   --quick   one repetition, short micro-benchmarks, `ieslam run` on the first 150 frames,
#             no step-20 registration. A full run with REPEAT=1 took 15 min on this shared
#             machine at load average ~10 (the two 500-frame runs and the simulation dominate).
# Environment: REPEAT (repetitions of the micro-benchmarks, register and run: default 3, 1
#   with --quick), SIM_REPEAT (default 1), BUILD_DIR (default build/),
#   JOBS (parallel compile jobs if a build is needed, default 1: the machine is shared),
#   BENCH_DATA (where the synthetic datasets are kept, default OUT/data).
#
# End to end:
#   register  `ieslam register --step 5` (and 20) with OpenCV on one thread: the front end's
#             accuracy and front-end ms per frame
#   run       `ieslam run` on 7scenes-dev, once --threads 1 (sequential) and once with the
#             default threads (frames prefetched on a worker), each under /usr/bin/time -v
#             for the peak resident memory
#   simulate  `ieslam simulate --buffers 3` (once; SIM_REPEAT for more): the Table I time
#             and dimension ratios
#   maps      `ieslam run` on the first half of 7scenes-dev (frames 0-249) and of
#             tum-fr1-rpy-300 (0-149), then `ieslam localize` of the second half in that map
#             (REPEAT times, under /usr/bin/time -v): localised share, ATE in the map frame,
#             real-time factor, map load time; then (once) `ieslam run --map` over the
#             second half and one run over the whole sequence: keyframe ATE of both
#   scale     (not with --quick) `ieslam run` on tum-fr1-rpy-300 and on `ieslam synth
#             --frames 600/2000 --seed 5`, default threads and --threads 1: real-time factor
#             (30 Hz), last-to-first quarter cost per frame (and the last quarter's frames
#             run on their own, which splits it into the map's size and the content), peak
#             RSS and its growth per
#             non-keyframe between 600 and 2,000 frames; `--refine` on tum-fr1-rpy-300 with the
#             default selector and with `--selector interval --interval 1`; `simulate
#             --buffers 3` with `filter: {iterative_recovery: 0}`. Once each. Renders the two
#             synthetic datasets (about 4 min) unless BENCH_DATA already holds them.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
quick=0
out=$root/bench_output
for arg in "$@"; do
  case "$arg" in
    --quick) quick=1 ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    -*) echo "bench.sh: unknown option $arg" >&2; exit 2 ;;
    *) out=$arg ;;
  esac
done
build_dir=${BUILD_DIR:-$root/build}
data=$root/../shared/data
if [ "$quick" = 1 ]; then
  repeat=${REPEAT:-1}
  # The all-frames filter benchmark alone takes a minute or more.
  micro_args=(--benchmark_min_time=0.05 --benchmark_filter=-PaperAllFrames)
  run_args=(--last 149)
else
  repeat=${REPEAT:-3}
  micro_args=()
  run_args=()
fi
if [ ! -d "$data/7scenes-dev" ]; then
  echo "bench.sh: $data/7scenes-dev not found (see ../shared/data/README.md)" >&2
  exit 1
fi

"$root/scripts/install_deps.sh"
# Release build of what is measured; make rebuilds only what changed.
if ! grep -qs '^CMAKE_BUILD_TYPE:STRING=Release$' "$build_dir/CMakeCache.txt" ||
   ! grep -qs '^IESLAM_BUILD_BENCHMARKS:BOOL=ON$' "$build_dir/CMakeCache.txt"; then
  cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DIESLAM_BUILD_BENCHMARKS=ON >/dev/null
fi
cmake --build "$build_dir" -j "${JOBS:-1}" --target ieslam ieslam_bench >/dev/null
ieslam=$build_dir/apps/ieslam
mkdir -p "$out"
rm -f "$out"/*.json "$out"/*.txt
started=$(date +%s)
uptime > "$out/load_before.txt"

echo "== micro-benchmarks ($repeat repetitions)" >&2
"$build_dir/tests/bench/ieslam_bench" --benchmark_repetitions="$repeat" \
  --benchmark_report_aggregates_only=true --benchmark_format=json "${micro_args[@]}" \
  > "$out/micro.json"

echo "== register" >&2
for r in $(seq "$repeat"); do
  OPENCV_FOR_THREADS_NUM=1 "$ieslam" register --dataset "$data/7scenes-dev" --step 5 \
    --output "$out/register5" --quiet > "$out/register5_$r.txt"
done
if [ "$quick" = 0 ]; then
  OPENCV_FOR_THREADS_NUM=1 "$ieslam" register --dataset "$data/7scenes-dev" --step 20 \
    --output "$out/register20" --quiet > "$out/register20_1.txt"
fi

echo "== run (sequential and pipelined)" >&2
for r in $(seq "$repeat"); do
  for mode in sequential pipelined; do
    threads=()
    [ "$mode" = sequential ] && threads=(--threads 1)
    /usr/bin/time -v "$ieslam" run --dataset "$data/7scenes-dev" --output "$out/run_$mode" \
      "${threads[@]}" "${run_args[@]}" --quiet 2> "$out/run_${mode}_time_$r.txt" > /dev/null
    cp "$out/run_$mode/report.json" "$out/run_${mode}_report_$r.json"
  done
done
if cmp -s "$out/run_sequential/trajectory.tum" "$out/run_pipelined/trajectory.tum"; then
  echo same > "$out/run_trajectories_identical.txt"
else
  echo different > "$out/run_trajectories_identical.txt"
fi

# The all-frames EIF of the simulation takes minutes: once, unless SIM_REPEAT says more.
echo "== simulate" >&2
for r in $(seq "${SIM_REPEAT:-1}"); do
  "$ieslam" simulate --output "$out/simulate" --runs 1 --buffers 3 --quiet > /dev/null
  cp "$out/simulate/report.json" "$out/simulate_report_$r.json"
done

# Maps: the first half of a sequence mapped, the second half localised in that map.
echo "== maps" >&2
map_case() {  # NAME DATASET LAST_MAPPED_FRAME
  local name=$1 dataset=$2 last=$3
  "$ieslam" run --dataset "$dataset" --last "$last" --output "$out/map_$name" --quiet > /dev/null
  for r in $(seq "$repeat"); do
    /usr/bin/time -v "$ieslam" localize --map "$out/map_$name" --dataset "$dataset" \
      --first $((last + 1)) --output "$out/localize_$name" --quiet \
      2> "$out/localize_${name}_time_$r.txt" > /dev/null
    cp "$out/localize_$name/report.json" "$out/localize_${name}_report_$r.json"
  done
  "$ieslam" run --map "$out/map_$name" --dataset "$dataset" --first $((last + 1)) \
    --output "$out/continue_$name" --quiet > /dev/null
  "$ieslam" run --dataset "$dataset" --output "$out/single_$name" --quiet > /dev/null
}
map_case 7scenes "$data/7scenes-dev" 249
map_case rpy "$data/tum-fr1-rpy-300" 149

# Scale: real-time factors on the real data and long synthetic sequences, both thread
# modes, the cost per frame over the run, peak memory and its growth per frame, the
# refinement's time on a small and a large problem, and the paper's exact EIF (no iterative
# recovery) against the selector. Synthetic datasets are rendered once into BENCH_DATA
# (default OUT/data) and reused.
if [ "$quick" = 0 ]; then
  echo "== scale" >&2
  synth_dir=${BENCH_DATA:-$out/data}
  for n in 600 2000; do
    if [ ! -f "$synth_dir/synth_$n/groundtruth.txt" ]; then
      "$ieslam" synth --output "$synth_dir/synth_$n" --frames "$n" --seed 5 > /dev/null
    fi
  done
  scale_run() {  # NAME, then the run's flags
    local name=$1
    shift
    /usr/bin/time -v "$ieslam" run --output "$out/scale_$name" --quiet "$@" \
      2> "$out/scale_${name}_time.txt" > /dev/null
    cp "$out/scale_$name/report.json" "$out/scale_${name}_report.json"
  }
  rpy=$data/tum-fr1-rpy-300
  scale_run rpy --dataset "$rpy"
  scale_run rpy_threads1 --dataset "$rpy" --threads 1
  scale_run synth600 --dataset "$synth_dir/synth_600"
  scale_run synth2000 --dataset "$synth_dir/synth_2000"
  scale_run synth2000_threads1 --dataset "$synth_dir/synth_2000" --threads 1
  # The last quarter's frames on their own (frames 225-299 of 300, 1500-1999 of 2,000):
  # the same content without the map before them. Against the whole run's last quarter, the
  # cost per frame that the map's size adds; against its first quarter, what the content does.
  scale_run rpy_last_quarter --dataset "$rpy" --first 225
  scale_run synth2000_last_quarter --dataset "$synth_dir/synth_2000" --first 1500
  scale_run rpy_refine --dataset "$rpy" --refine
  scale_run rpy_refine_interval1 --dataset "$rpy" --selector interval --interval 1 --refine
  printf 'filter:\n  iterative_recovery: 0\n' > "$out/exact_eif.yaml"
  "$ieslam" simulate --output "$out/simulate_exact" --runs 1 --buffers 3 \
    --config "$out/exact_eif.yaml" --quiet > /dev/null
  cp "$out/simulate_exact/report.json" "$out/simulate_exact_report.json"
fi

uptime > "$out/load_after.txt"
echo $(( $(date +%s) - started )) > "$out/bench_seconds.txt"
git -C "$root" rev-parse --short HEAD > "$out/commit.txt" 2>/dev/null || echo unknown > "$out/commit.txt"
/usr/bin/python3 "$root/scripts/bench_table.py" "$out" "$repeat" "$quick"
