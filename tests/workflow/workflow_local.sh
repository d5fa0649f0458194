#!/usr/bin/env bash
# The tiny benchmark workflow on this machine with 2 cores: every combination reaches
# RESULTS.md and results.csv, the runs made to fail are in its failed-runs table with their
# log, and a second invocation has nothing to redo.
#   workflow_local.sh IESLAM SOURCE_DIR
set -euo pipefail
IESLAM=$1
SOURCE=$2
source "$SOURCE/tests/workflow/common.sh"
if ! command -v snakemake >/dev/null; then
  echo "workflow_local: snakemake is not installed (scripts/install_deps.sh)" >&2
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
run_tiny_workflow "$work" --cores 2
check_results "$work"
# Reruns only what changed: here nothing.
if ! run_tiny_workflow "$work" --cores 2 -n | grep -q "Nothing to be done"; then
  run_tiny_workflow "$work" --cores 2 -n --reason >&2 || true
  echo "workflow_local: a second invocation wants to redo jobs" >&2
  exit 1
fi
echo "workflow_local: ok"
