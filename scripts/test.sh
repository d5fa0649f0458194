#!/usr/bin/env bash
# The README's test command: installs what is missing, builds, runs every test through ctest;
# then builds the libraries' tests again with AddressSanitizer + UndefinedBehaviorSanitizer (in
# ASAN_BUILD_DIR, default build-asan/) and runs them (SANITIZE=0 skips this second pass).
# Exits non-zero on any failure, a sanitizer report included.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=${BUILD_DIR:-$root/build}

"$root/scripts/install_deps.sh"
BUILD_DIR=$build_dir "$root/scripts/build.sh"
cd "$build_dir"
ctest --output-on-failure -j "$(nproc)" --timeout 600

if [ "${SANITIZE:-1}" != 0 ]; then
  # The libraries' tests (core, frontend, backend, selection) under the sanitizers, built at
  # -O1: a second -O3 build of everything, the command-line binary included, would take CI
  # longer than the rest of the run together; the apps tests drive the binary in the
  # Release pass above.
  asan_dir=${ASAN_BUILD_DIR:-$root/build-asan}
  cmake -S "$root" -B "$asan_dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O1 -g0" \
    -DIESLAM_SANITIZE=ON -DIESLAM_BUILD_BENCHMARKS=OFF >/dev/null
  targets=$(cmake --build "$asan_dir" --target help | sed -n 's/^\.\.\. \(\(core\|frontend\|backend\|selection\)_[a-z_]*_test\)$/\1/p')
  # shellcheck disable=SC2086
  cmake --build "$asan_dir" -j "${JOBS:-$(nproc)}" --target $targets
  cd "$asan_dir"
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --output-on-failure -j "$(nproc)" --timeout 600 -L "core|frontend|backend|selection" -LE long
fi
