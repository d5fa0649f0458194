#!/usr/bin/env bash
# The README's test command: installs what is missing, builds, runs every test through ctest;
# then builds the tests again with AddressSanitizer + UndefinedBehaviorSanitizer (in
# ASAN_BUILD_DIR, default build-asan/) and runs them, but for the end-to-end runs labelled
# `long`, which the Release run covers (SANITIZE=0 skips this second pass).
# Exits non-zero on any failure, a sanitizer report included.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=${BUILD_DIR:-$root/build}

"$root/scripts/install_deps.sh"
BUILD_DIR=$build_dir "$root/scripts/build.sh"
cd "$build_dir"
ctest --output-on-failure -j "$(nproc)" --timeout 600

if [ "${SANITIZE:-1}" != 0 ]; then
  asan_dir=${ASAN_BUILD_DIR:-$root/build-asan}
  BUILD_DIR=$asan_dir "$root/scripts/build.sh" -DIESLAM_SANITIZE=ON -DIESLAM_BUILD_BENCHMARKS=OFF
  cd "$asan_dir"
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --output-on-failure -j "$(nproc)" --timeout 600 -LE long
fi
