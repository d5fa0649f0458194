#!/usr/bin/env bash
# Installs the Debian packages ieslam needs, if any are missing. Non-interactive; works as
# root or through sudo. Every dependency is a Debian package: nothing is downloaded otherwise.
set -euo pipefail

packages=(
  cmake g++ make pkg-config clang-format
  libceres-dev libeigen3-dev libopencv-dev libopengv-dev libflann-dev libsuitesparse-dev
  libgtest-dev libbenchmark-dev zlib1g-dev
  python3-matplotlib pybind11-dev python3-numpy python3-pytest
  snakemake slurm-wlm slurm-client munge time
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "ieslam: installing missing Debian packages: ${missing[*]}" >&2
if [ "$(id -u)" -eq 0 ]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "ieslam: need root or sudo to install: ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -q
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
