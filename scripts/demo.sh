#!/usr/bin/env bash
# The README's first command: installs what is missing, builds Release, and runs ieslam on
# its embedded default, writing the results (with plots) to OUT (default: demo_output/).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-$root/demo_output}
build_dir=${BUILD_DIR:-$root/build}

"$root/scripts/install_deps.sh"
BUILD_DIR=$build_dir "$root/scripts/build.sh"
ieslam=$build_dir/apps/ieslam
mkdir -p "$out"

"$ieslam" --help
echo
echo "ieslam demo: results in $out"
