# Shared by the workflow tests: runs the tiny workflow (workflow/test_config.yaml) and checks
# and compares its results. Sourced; expects IESLAM (the binary) and SOURCE (the repository).

# run_tiny_workflow DIR [snakemake flags...]: the tiny workflow with its outputs in DIR/out.
run_tiny_workflow() {
  local dir=$1
  shift
  snakemake -s "$SOURCE/workflow/Snakefile" --configfile "$SOURCE/workflow/test_config.yaml" \
    --config ieslam="$IESLAM" outdir="$dir/out" --directory "$dir" --quiet "$@"
}

# check_results DIR: RESULTS.md and results.csv list every combination of the tiny config,
# and RESULTS.md every run of synth_cut (made to fail) among the failed runs.
check_results() {
  /usr/bin/python3 - "$1/out" <<'PY'
import csv, sys
out = sys.argv[1]
page = open(f"{out}/RESULTS.md").read()
rows = list(csv.DictReader(open(f"{out}/results.csv")))
runs = list(csv.DictReader(open(f"{out}/runs.csv")))
want = {(d, s, b) for d in ("synth_tiny", "synth_cut") for s, b in (("info", "3"), ("all", "0"))}
got = {(r["dataset"], r["selector"], r["buffer"]) for r in rows}
assert got == want, f"results.csv groups {got}, expected {want}"
assert len(runs) == 8, f"runs.csv has {len(runs)} runs, expected 8"
for r in runs:
    assert r["ok"] == ("1" if r["dataset"] == "synth_tiny" else "0"), f"runs.csv: {r}"
for r in rows:
    if r["dataset"] == "synth_tiny":
        assert r["ok"] == "2" and r["ate_filter_m_mean"], f"results.csv row {r}"
for name in ("| synth_tiny | info (buffer 3) | 2/2 |", "| synth_tiny | all | 2/2 |",
             "| synth_cut | all | 0/2 |", "Monte-Carlo simulation", "commit `"):
    assert name in page, f"RESULTS.md lacks '{name}'"
# Every failed run in the failed-runs table, with its message.
failed = page.split("## Failed runs", 1)[1].split("\n## ", 1)[0]
for seed in ("1", "2"):
    for selector, buffer in (("info", "3"), ("all", "0")):
        line = f"| synth_cut | {selector} | {buffer} | {seed} | run exited 3 |"
        assert line in failed, f"RESULTS.md's failed runs lack '{line}'"
assert "first = 500" in failed, "RESULTS.md's failed runs lack the log's tail"
print(f"{out}: {len(runs)} runs, {len(rows)} groups, all listed, the 4 failed ones too")
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
