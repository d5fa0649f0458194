# Shared by the workflow tests: runs the tiny workflow (workflow/test_config.yaml) and checks
# and compares its results. Sourced; expects IESLAM (the binary) and SOURCE (the repository).

# run_tiny_workflow DIR [snakemake flags...]: the tiny workflow with its outputs in DIR/out.
run_tiny_workflow() {
  local dir=$1
  shift
  snakemake -s "$SOURCE/workflow/Snakefile" --configfile "$SOURCE/workflow/test_config.yaml" \
    --config ieslam="$IESLAM" outdir="$dir/out" --directory "$dir" --quiet "$@"
}

# check_results DIR: RESULTS.md and results.csv list every combination of the tiny config.
check_results() {
  /usr/bin/python3 - "$1/out" <<'PY'
import csv, sys
out = sys.argv[1]
page = open(f"{out}/RESULTS.md").read()
rows = list(csv.DictReader(open(f"{out}/results.csv")))
runs = list(csv.DictReader(open(f"{out}/runs.csv")))
want = {("synth_tiny", "info", "3"), ("synth_tiny", "all", "0")}
got = {(r["dataset"], r["selector"], r["buffer"]) for r in rows}
assert got == want, f"results.csv groups {got}, expected {want}"
assert len(runs) == 4 and all(r["ok"] == "1" for r in runs), f"runs.csv: {runs}"
for r in rows:
    assert r["ok"] == "2" and r["ate_filter_m_mean"], f"results.csv row {r}"
for name in ("| synth_tiny | info (buffer 3) | 2/2 |", "| synth_tiny | all | 2/2 |",
             "Monte-Carlo simulation", "## Failed runs", "commit `"):
    assert name in page, f"RESULTS.md lacks '{name}'"
print(f"{out}: {len(runs)} runs, {len(rows)} groups, all listed")
PY
}

# same_results A B: results.csv and runs.csv of two runs equal but for timings and memory.
same_results() {
  /usr/bin/python3 - "$1/out" "$2/out" <<'PY'
import csv, sys
def timing(column):
    base = column.rsplit("_", 1)[0] if column.endswith(("_mean", "_std")) else column
    return base.endswith("_s") or base in ("rtf", "peak_mem_mb", "log_tail")
def table(path):
    rows = list(csv.DictReader(open(path)))
    return [{k: v for k, v in r.items() if not timing(k)} for r in rows]
for name in ("results.csv", "runs.csv"):
    a, b = table(f"{sys.argv[1]}/{name}"), table(f"{sys.argv[2]}/{name}")
    assert a == b, f"{name} differs:\n{a}\n{b}"
print("results equal but for timing and memory columns")
PY
}
