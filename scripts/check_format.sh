#!/usr/bin/env bash
# Fails, naming the files, when a C++ source of the project is not formatted as .clang-format
# says (ctest runs it as the test `clang_format`). `clang-format -i FILE` fixes one.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
format=${CLANG_FORMAT:-clang-format}
mapfile -t sources < <(find core frontend backend selection apps tests -name '*.h' -o -name '*.cc' | sort)
bad=()
for f in "${sources[@]}"; do
  "$format" --dry-run -Werror "$f" > /dev/null 2>&1 || bad+=("$f")
done
if [ ${#bad[@]} -gt 0 ]; then
  echo "check_format: ${#bad[@]} of ${#sources[@]} files are not clang-format clean (clang-format -i FILE):" >&2
  printf '  %s\n' "${bad[@]}" >&2
  exit 1
fi
echo "check_format: ${#sources[@]} files clang-format clean"
