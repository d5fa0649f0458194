#!/usr/bin/env bash
# Reproduces docs/benchmark/ (RESULTS.md, results.csv, results.tex, plots/) from scratch:
# runs the benchmark workflow of workflow/config.yaml into a new output directory on this
# machine's cores, then writes its report into docs/benchmark/ with how long the workflow
# took and how many cores it kept busy (the CPU time of all its jobs over its wall time).
#
#   scripts/results.sh [OUTDIR]     (default: results-YYYYmmdd-HHMMSS in the repository)
#   CORES=N scripts/results.sh      (default: nproc)
#
# Builds build/apps/ieslam first if it is missing (the build's time is not counted).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
out=${1:-$root/results-$(date -u +%Y%m%d-%H%M%S)}
cores=${CORES:-$(nproc)}
if [ -e "$out" ]; then
  echo "results.sh: $out exists; give a directory that does not (the run is from scratch)" >&2
  exit 2
fi
if [ ! -x build/apps/ieslam ]; then
  scripts/install_deps.sh
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build build -j "$cores" --target ieslam
fi
mkdir -p "$out"
out=$(cd "$out" && pwd)

# /usr/bin/time counts the CPU time of snakemake and of every job it waited for.
/usr/bin/time -f "%e %U %S" -o "$out/workflow_time.txt" \
  snakemake -s workflow/Snakefile --configfile workflow/config.yaml --cores "$cores" \
  --keep-going --rerun-incomplete --config outdir="$out" ieslam="$root/build/apps/ieslam" \
  >"$out/workflow.log" 2>&1 || {
  echo "results.sh: the workflow failed; its log: $out/workflow.log" >&2
  tail -20 "$out/workflow.log" >&2
  exit 1
}

/usr/bin/python3 - "$out" "$cores" "$root/docs/benchmark" <<'EOF'
import os, shutil, sys, tempfile
out, cores, dest = sys.argv[1], int(sys.argv[2]), sys.argv[3]
wall, user, system = (float(x) for x in open(os.path.join(out, "workflow_time.txt")).read().split()[-3:])
busy = (user + system) / wall if wall > 0 else 0.0
section = (
    "\n## How long it took\n\n"
    f"From scratch with `scripts/results.sh` on {cores} cores: {wall / 60:.1f} min wall; "
    f"the workflow's jobs used {(user + system) / 60:.1f} min of CPU, "
    f"{busy:.2f} cores busy on average.\n"
)
# Written beside the old report, then swapped in: a failed copy leaves the old one whole.
parent = os.path.dirname(dest)
os.makedirs(parent, exist_ok=True)
staging = tempfile.mkdtemp(prefix=".benchmark.", dir=parent)
shutil.copy(os.path.join(out, "results.csv"), staging)
shutil.copy(os.path.join(out, "results.tex"), staging)
shutil.copytree(os.path.join(out, "plots"), os.path.join(staging, "plots"))
with open(os.path.join(staging, "RESULTS.md"), "w") as f:
    f.write(open(os.path.join(out, "RESULTS.md")).read().rstrip("\n") + "\n" + section)
old = dest + ".old"
if os.path.exists(dest):
    os.rename(dest, old)
os.rename(staging, dest)
shutil.rmtree(old, ignore_errors=True)
print(section.strip())
print(f"results.sh: {dest}/RESULTS.md (the workflow's outputs: {out})")
EOF
