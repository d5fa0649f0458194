#!/usr/bin/python3
"""Snakemake's --cluster-status for Slurm: prints running, success or failed for a job id.

Asks squeue, then scontrol (a finished job stays there for MinJobAge seconds); a job neither
knows has been purged after finishing, which Snakemake then judges by its output files.
"""
import subprocess
import sys

job = sys.argv[1]
RUNNING = {"PENDING", "RUNNING", "CONFIGURING", "COMPLETING", "SUSPENDED", "REQUEUED",
           "RESIZING", "STAGE_OUT"}


def state():
    out = subprocess.run(["squeue", "-h", "-j", job, "-o", "%T"], capture_output=True, text=True)
    if out.returncode == 0 and out.stdout.strip():
        return out.stdout.split()[0]
    out = subprocess.run(["scontrol", "show", "job", "-o", job], capture_output=True, text=True)
    for field in out.stdout.split():
        if field.startswith("JobState="):
            return field.split("=", 1)[1]
    return "COMPLETED"


s = state()
print("running" if s in RUNNING else "success" if s == "COMPLETED" else "failed")
