#!/usr/bin/python3
"""Runs a command so that its failure is a result, not a failed workflow job.

    wrapped.py STATUS.json -- COMMAND ARGS...

Runs COMMAND under /usr/bin/time -v with its output in log.txt beside STATUS.json, then
writes STATUS.json: {"ok", "exit_code", "wall_seconds", "peak_rss_kb", "log_tail", "command"}.
Exits 0 whatever the command did, so that the workflow goes on and the report lists the
failure (a workflow engine's --keep-going would drop the failed run's downstream results).
"""
import json
import os
import re
import subprocess
import sys
import time


def main():
    status_path = sys.argv[1]
    command = sys.argv[sys.argv.index("--") + 1:]
    directory = os.path.dirname(os.path.abspath(status_path))
    os.makedirs(directory, exist_ok=True)
    log_path = os.path.join(directory, "log.txt")
    time_path = os.path.join(directory, "time.txt")
    start = time.monotonic()
    with open(log_path, "wb") as log:
        exit_code = subprocess.call(
            ["/usr/bin/time", "-v", "-o", time_path] + command, stdout=log, stderr=subprocess.STDOUT
        )
    wall = time.monotonic() - start
    peak_rss_kb = None
    if os.path.exists(time_path):
        match = re.search(r"Maximum resident set size \(kbytes\): (\d+)", open(time_path).read())
        if match:
            peak_rss_kb = int(match.group(1))
    with open(log_path, "rb") as log:
        lines = log.read().decode("utf-8", "replace").splitlines()
    status = {
        "ok": exit_code == 0,
        "exit_code": exit_code,
        "wall_seconds": wall,
        "peak_rss_kb": peak_rss_kb,
        "log_tail": "\n".join(lines[-15:]),
        "command": " ".join(command),
    }
    temp = status_path + ".tmp"
    with open(temp, "w") as f:
        json.dump(status, f, indent=2)
    os.replace(temp, status_path)


if __name__ == "__main__":
    main()
