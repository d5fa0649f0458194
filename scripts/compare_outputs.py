#!/usr/bin/env python3
"""Compares two trees written by scripts/regression_outputs.sh (before and after a change).

Every file must be byte-identical, except for what measures time, which is masked:
  - JSON files are compared as parsed values without the keys that hold times (any key
    containing "seconds", and "ms_per_frame", "solve_time_s", "covariance_time_s");
  - Markdown tables (table.md, simulate's stdout) without their time columns;
  - stdout lines that print a time ("refine: ... s", "register.ms_per_frame").
Keys that only the second tree's JSON has, and `key value` lines that only its stdout has
(every line of the first still there, in order), are listed as additions (a new option in a
report, a new figure printed) and do not count as a difference unless --strict; every other difference,
missing file or changed exit code does. stderr is compared too, and its differences are
listed as warnings (messages may be reworded by a refactor; outputs may not).

Usage: scripts/compare_outputs.py BEFORE AFTER [--strict] [--subset]
  --subset: AFTER may hold fewer files (a --quick run against a full one): files only in
            BEFORE are not differences.
Exit status: 0 identical (but for times and additions), 1 different.
"""
import json
import os
import re
import sys

TIME_KEYS = ("ms_per_frame", "solve_time_s", "covariance_time_s")


def is_time_key(key):
    return "seconds" in key or key in TIME_KEYS


def strip_times(value):
    if isinstance(value, dict):
        return {k: strip_times(v) for k, v in value.items() if not is_time_key(k)}
    if isinstance(value, list):
        return [strip_times(v) for v in value]
    return value


def json_diff(a, b, path, diffs, additions):
    if isinstance(a, dict) and isinstance(b, dict):
        for key in a:
            if key not in b:
                diffs.append(f"{path}.{key}: missing after")
            else:
                json_diff(a[key], b[key], f"{path}.{key}", diffs, additions)
        for key in b:
            if key not in a:
                additions.append(f"{path}.{key} = {json.dumps(b[key])[:80]}")
        return
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            diffs.append(f"{path}: {len(a)} elements before, {len(b)} after")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            json_diff(x, y, f"{path}[{i}]", diffs, additions)
        return
    if a != b or type(a) is not type(b):
        diffs.append(f"{path}: {json.dumps(a)[:80]} before, {json.dumps(b)[:80]} after")


def mask_markdown_times(text):
    """Blanks the cells of table columns whose header says time."""
    lines = text.split("\n")
    masked, time_columns = [], []
    for line in lines:
        if line.startswith("|"):
            cells = line.split("|")
            if not re.fullmatch(r"[|\-\s]*", line) and any(c.strip().startswith("selector") or
                                                          c.strip() == "buffer" for c in cells):
                time_columns = [i for i, c in enumerate(cells) if c.strip().startswith("time")]
            for i in time_columns:
                if i < len(cells) and not re.fullmatch(r"-*", cells[i].strip()):
                    cells[i] = " <time> "
            line = "|".join(cells)
        else:
            time_columns = [] if not line.strip() else time_columns
        masked.append(line)
    return "\n".join(masked)


def mask_stdout(text):
    text = mask_markdown_times(text)
    text = re.sub(r"(register\.ms_per_frame )\S+", r"\1<time>", text)
    text = re.sub(r"(refine: .*, )[0-9.]+ s$", r"\1<time> s", text, flags=re.M)
    return text


KEY_VALUE = re.compile(r"^[\w.]+ \S+$")


def stdout_diff(a, b, name):
    """Differences and additions between two masked stdouts: `key value` lines only the second
    has (a new figure printed) are additions when every line of the first is there, in order."""
    if a == b:
        return [], []
    before, after = a.split("\n"), b.split("\n")
    added, i = [], 0
    for line in after:
        if i < len(before) and line == before[i]:
            i += 1
        elif KEY_VALUE.match(line):
            added.append(f"{name}: {line}")
        else:
            return [f"{name}: differs (times masked)"], []
    if i < len(before):
        return [f"{name}: differs (times masked)"], []
    return [], added


def read_masking_root(root, name):
    """The file's bytes, with the tree's own path (which the outputs name) as <OUT> and the
    source tree the binary was built from (calibration paths) as <SRC>."""
    with open(os.path.join(root, name), "rb") as f:
        data = f.read()
    if name.endswith((".json", ".stdout", ".stderr", ".md", ".txt", ".tum")):
        data = data.replace(os.path.realpath(root).encode(), b"<OUT>")
        source = os.path.join(root, "source_root")
        if os.path.exists(source):
            with open(source, "rb") as f:
                src = f.read().strip()
            if src:
                data = data.replace(src, b"<SRC>")
    return data


def files(root):
    found = set()
    for directory, _, names in os.walk(root):
        for name in names:
            found.add(os.path.relpath(os.path.join(directory, name), root))
    return found


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    strict = "--strict" in sys.argv
    subset = "--subset" in sys.argv
    if len(args) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    before, after = args
    a_files, b_files = files(before), files(after)
    differences, warnings, additions = [], [], []
    for name in sorted(a_files - b_files):
        if not subset:
            differences.append(f"{name}: only before")
    for name in sorted(b_files - a_files):
        differences.append(f"{name}: only after")
    for name in sorted(a_files & b_files):
        if name in ("commands.log", "source_root"):
            continue
        a = read_masking_root(before, name)
        b = read_masking_root(after, name)
        if name.endswith(".json"):
            diffs, added = [], []
            json_diff(strip_times(json.loads(a)), strip_times(json.loads(b)), name, diffs, added)
            differences += diffs
            additions += added
        elif name.endswith(".md"):
            if mask_markdown_times(a.decode()) != mask_markdown_times(b.decode()):
                differences.append(f"{name}: differs (time columns masked)")
        elif name.endswith(".stdout"):
            diffs, added = stdout_diff(mask_stdout(a.decode()), mask_stdout(b.decode()), name)
            differences += diffs
            additions += added
        elif name.endswith(".stderr"):
            if a != b:
                warnings.append(f"{name}: differs")
        elif a != b:
            differences.append(f"{name}: bytes differ")
    if strict:
        differences += [f"addition: {a}" for a in additions]
    for line in additions if not strict else []:
        print(f"added: {line}")
    for line in warnings:
        print(f"warning: {line}")
    for line in differences:
        print(f"DIFFERENT: {line}")
    compared = len(a_files & b_files)
    if differences:
        print(f"compare_outputs: {len(differences)} difference(s) over {compared} files")
        return 1
    print(f"compare_outputs: {compared} files identical but for times"
          f" ({len(additions)} added JSON keys, {len(warnings)} stderr warnings)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
