#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz with clang (ASan + UBSan) in BUILD_DIR
# (default build-fuzz/) and runs each for at most FUZZ_RUNS executions (default 10^6) or
# FUZZ_SECONDS seconds (default 1800), whichever comes first; prints each target's execution
# count. Installs clang and libFuzzer (Debian: clang, libclang-rt-14-dev) when missing.
# Exits non-zero when a target finds a crash, a sanitizer report, a broken invariant or an
# input that runs longer than FUZZ_TIMEOUT seconds (default 60: a unit takes milliseconds, and
# with libFuzzer's default of 1200 s a hang stalls the run instead of failing it); the input is
# then in BUILD_DIR/artifacts/. Usage: scripts/fuzz.sh [target ...]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=${BUILD_DIR:-$root/build-fuzz}
runs=${FUZZ_RUNS:-1000000}
seconds=${FUZZ_SECONDS:-1800}
timeout=${FUZZ_TIMEOUT:-60}

packages=(clang libclang-rt-14-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "fuzz: installing missing Debian packages: ${missing[*]}" >&2
  as_root=()
  [ "$(id -u)" -eq 0 ] || as_root=(sudo)
  "${as_root[@]}" apt-get update -q
  "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
    "${missing[@]}"
fi
"$root/scripts/install_deps.sh"

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for source in "$root"/tests/fuzz/*_fuzz.cc; do targets+=("$(basename "$source" .cc)"); done
fi

CXX=clang++ cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DIESLAM_BUILD_FUZZERS=ON -DIESLAM_BUILD_TESTS=OFF -DIESLAM_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$build_dir" -j "${JOBS:-$(nproc)}" --target "${targets[@]}"

mkdir -p "$build_dir/artifacts"
declare -A dicts=([calibration_fuzz]=calibration.dict [stamped_list_fuzz]=tum.dict
                  [tum_trajectory_fuzz]=tum.dict)
status=0
summary=""
for target in "${targets[@]}"; do
  corpus="$build_dir/corpus/$target"  # grows here; the seeds in the tree stay as they are
  mkdir -p "$corpus"
  dict=()
  [ -n "${dicts[$target]:-}" ] && dict=(-dict="$root/tests/fuzz/${dicts[$target]}")
  log="$build_dir/$target.log"
  echo "fuzz: $target (up to $runs runs or $seconds s)"
  if ASAN_OPTIONS=detect_leaks=1 "$build_dir/tests/fuzz/$target" "$corpus" \
       "$root/tests/fuzz/seeds/$target" "${dict[@]}" -runs="$runs" -max_total_time="$seconds" \
       -max_len=4096 -timeout="$timeout" -print_final_stats=1 \
       -artifact_prefix="$build_dir/artifacts/$target-" \
       >"$log" 2>&1; then
    result=ok
  else
    result="FAILED (see $log and $build_dir/artifacts/)"
    status=1
  fi
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  per_s=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  summary+=$(printf '%-22s %10s executions  %7s exec/s  %s' "$target" "${execs:-?}" \
    "${per_s:-?}" "$result")$'\n'
done
printf '\n%s' "$summary"
exit $status
