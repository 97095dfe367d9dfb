#!/usr/bin/env python3
"""Compares the report values of two folders of runs.

    python3 scripts/compare_reports.py BEFORE AFTER [--rtol 1e-10]

BEFORE and AFTER each hold one sub-folder per case with its `report.json`
(`cgfem-gpu run cases/<name>.toml --out BEFORE/<name>`). Every number of the
two reports is compared, key by key and row by row, to `rtol` relative (an
absolute floor of `rtol` times the largest magnitude of that list or row
keeps values that are zero to round-off comparable); strings, booleans and
the shapes of lists must be equal. What depends on the machine and not on
the answer is skipped: `timings`, the adapter and the memory figures. Prints
one line per case and every difference; exits 1 if any case differs or is
missing on one side.
"""
import argparse
import json
import math
import os
import sys

SKIPPED = {"timings", "adapter", "memory", "peak_memory_bytes", "file", "threads"}


STATS = {"numbers": 0, "max_relative": 0.0}


def walk(a, b, path, rtol, scale, out):
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if key in SKIPPED:
                continue
            if key not in a or key not in b:
                out.append(f"{path}.{key}: only in {'after' if key not in a else 'before'}")
                continue
            walk(a[key], b[key], f"{path}.{key}", rtol, scale, out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: {len(a)} entries before, {len(b)} after")
            return
        numbers = [abs(x) for x in a + b if isinstance(x, (int, float)) and not isinstance(x, bool)]
        finite = [x for x in numbers if math.isfinite(x)]
        row_scale = max(finite) if finite else scale
        for i, (x, y) in enumerate(zip(a, b)):
            walk(x, y, f"{path}[{i}]", rtol, row_scale, out)
    elif isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or a is None:
        if a != b:
            out.append(f"{path}: {a!r} before, {b!r} after")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if math.isnan(a) and math.isnan(b):
            return
        STATS["numbers"] += 1
        if a != b and math.isfinite(a) and math.isfinite(b):
            STATS["max_relative"] = max(STATS["max_relative"], abs(a - b) / max(abs(a), abs(b)))
        tol = rtol * max(abs(a), abs(b), scale)
        if not (abs(a - b) <= tol or a == b):
            rel = abs(a - b) / max(abs(a), abs(b))
            out.append(f"{path}: {a!r} before, {b!r} after ({rel:.1e} relative)")
    elif a != b:
        out.append(f"{path}: {a!r} before, {b!r} after")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("before")
    p.add_argument("after")
    p.add_argument("--rtol", type=float, default=1e-10)
    args = p.parse_args()
    cases = sorted(
        name
        for d in (args.before, args.after)
        for name in os.listdir(d)
        if os.path.isdir(os.path.join(d, name))
    )
    cases = sorted(set(cases))
    failed = 0
    for case in cases:
        reports = [os.path.join(d, case, "report.json") for d in (args.before, args.after)]
        if not all(os.path.exists(r) for r in reports):
            print(f"{case}: report.json missing on one side")
            failed += 1
            continue
        a, b = (json.load(open(r)) for r in reports)
        out = []
        STATS.update(numbers=0, max_relative=0.0)
        walk(a, b, case, args.rtol, 0.0, out)
        verdict = "same" if not out else f"{len(out)} differences"
        print(
            f"{case}: {verdict} ({STATS['numbers']} numbers, largest relative "
            f"difference {STATS['max_relative']:.1e})"
        )
        for line in out:
            print("  " + line)
        failed += bool(out)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
