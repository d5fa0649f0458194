#!/usr/bin/env bash
# The tiny benchmark workflow through Slurm: a one-node cluster on localhost from the Debian
# packages (munged with a key made here, slurmctld, slurmd, a slurm.conf written here, every
# state and spool directory in a temporary one), the workflow submitted through the slurm
# profile's sbatch, its results compared with a local run's. Exits 77 (skipped) only when
# the cluster cannot start: not root, a package missing, a daemon that does not come up.
#   workflow_slurm.sh IESLAM SOURCE_DIR
set -euo pipefail
IESLAM=$1
SOURCE=$2
source "$SOURCE/tests/workflow/common.sh"

skip() {
  echo "workflow_slurm: SKIPPED: $*" >&2
  exit 77
}
[ "$(id -u)" -eq 0 ] || skip "needs root to run munged, slurmctld and slurmd"
for tool in snakemake munged mungekey slurmctld slurmd sbatch sinfo scontrol; do
  command -v "$tool" >/dev/null || skip "$tool is not installed (scripts/install_deps.sh)"
done

work=$(mktemp -d /tmp/ieslam_workflow_slurm.XXXXXX)
chmod 755 "$work"
pids=()
stop() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  rm -rf "$work"
}
trap stop EXIT

# munge: its own key, socket and files, so that a system munged is left alone.
mkdir -p "$work/munge"
chmod 700 "$work/munge"
mungekey --create --keyfile="$work/munge/munge.key" >/dev/null 2>&1 ||
  skip "mungekey could not create a key"
chmod 600 "$work/munge/munge.key"
munged --foreground --force --key-file="$work/munge/munge.key" \
  --socket="$work/munge/munge.socket" --pid-file="$work/munge/munged.pid" \
  --log-file="$work/munge/munged.log" --seed-file="$work/munge/munged.seed" \
  >"$work/munge/stdout.log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$work/munge/munge.socket" ] && break; sleep 0.1; done
[ -S "$work/munge/munge.socket" ] || skip "munged did not start: $(tail -3 "$work/munge/munged.log" 2>/dev/null)"

# Ports off the defaults, so that a system Slurm is left alone too.
port=$((20000 + RANDOM % 20000))
memory_mb=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
mkdir -p "$work/slurm/state" "$work/slurm/spool"
export SLURM_CONF=$work/slurm/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=ieslamtest
SlurmctldHost=localhost
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$work/munge/munge.socket
StateSaveLocation=$work/slurm/state
SlurmdSpoolDir=$work/slurm/spool
SlurmctldPidFile=$work/slurm/slurmctld.pid
SlurmdPidFile=$work/slurm/slurmd.pid
SlurmctldLogFile=$work/slurm/slurmctld.log
SlurmdLogFile=$work/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=$memory_mb State=UNKNOWN
PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -D -i -f "$SLURM_CONF" >"$work/slurm/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N localhost -f "$SLURM_CONF" >"$work/slurm/slurmd.out" 2>&1 &
pids+=($!)
idle=""
for _ in $(seq 60); do
  state=$(sinfo -h -n localhost -o %t 2>/dev/null || true)
  if [ "$state" = idle ]; then
    idle=1
    break
  fi
  sleep 0.5
done
if [ -z "$idle" ]; then
  skip "the node did not become idle in 30 s (state '${state:-none}'): $(tail -3 "$work/slurm/slurmctld.log" "$work/slurm/slurmd.log" 2>/dev/null)"
fi
echo "workflow_slurm: Slurm up on localhost:$port ($(nproc) CPUs, $memory_mb MB)"

run_tiny_workflow "$work/local" --cores 2
run_tiny_workflow "$work/slurm" --profile "$SOURCE/workflow/profiles/slurm" || {
  tail -20 "$work"/slurm/logs/slurm/*.out >&2 || true
  exit 1
}
jobs=$(ls "$work/slurm/logs/slurm" | wc -l)
[ "$jobs" -gt 0 ] || { echo "workflow_slurm: no job went through sbatch" >&2; exit 1; }
check_results "$work/slurm"
same_results "$work/local" "$work/slurm"
echo "workflow_slurm: ok ($jobs jobs through sbatch)"
