#!/usr/bin/env python3
"""Compares the report of a run on several ranks with the run on one.

    python3 scripts/compare_ranks.py ONE/report.json RANKS/report.json

Both runs solve the same case with the same settings. Checks, and prints
each figure: the same Krylov method and preconditioner; the same outer
iterations; the same Krylov iterations in every solve (the ranks add their
dot products exactly and their V-cycle is the one-rank cycle, so they
repeat the one-rank iterations); the same energy and L2 errors and
reactions, to the bit (the sums over the body are exact); the same dofs and
cell counts. Exits 1 if any check fails.
"""
import json
import sys


def main():
    one, ranks = (json.load(open(p)) for p in sys.argv[1:3])
    failures = []

    def check(what, ok, detail):
        print(f"{'ok  ' if ok else 'FAIL'} {what}: {detail}")
        if not ok:
            failures.append(what)

    check("ranks", len(ranks.get("ranks", [])) > 1, f"{len(ranks.get('ranks', []))} rows")
    check("status", one["status"] == ranks["status"] == "ok", f"{one['status']}, {ranks['status']}")
    for key in ("method", "preconditioner"):
        a, b = one["krylov"][key], ranks["krylov"][key]
        check(f"Krylov {key}", a == b, f"{a} and {b}")
    a, b = one["fixed_point"]["iterations"], ranks["fixed_point"]["iterations"]
    check("outer iterations", a == b, f"{a} and {b}")
    a, b = one["krylov"]["total_iterations"], ranks["krylov"]["total_iterations"]
    same = one["krylov"]["iterations_per_solve"] == ranks["krylov"]["iterations_per_solve"]
    check("Krylov iterations, every solve", same, f"{a} and {b} in all")
    check("dofs", one["dofs"] == ranks["dofs"], f"{one['dofs']} and {ranks['dofs']}")
    ca, cb = one["bodies"][0]["cells"], ranks["bodies"][0]["cells"]
    for key in ("inside", "cut", "outside", "pathological"):
        check(f"cells.{key}", ca[key] == cb[key], f"{ca[key]} and {cb[key]}")
    ea, eb = one["bodies"][0].get("error"), ranks["bodies"][0].get("error")
    check("error norms present", (ea is None) == (eb is None), f"{ea is not None}, {eb is not None}")
    if ea and eb:
        for key in ("energy", "l2"):
            rel = abs(ea[key] - eb[key]) / abs(ea[key])
            check(f"{key} error", ea[key] == eb[key], f"{ea[key]!r} and {eb[key]!r} ({rel:.1e})")
    ra = {r["part"]: r["force"] for r in one["reactions"]}
    rb = {r["part"]: r["force"] for r in ranks["reactions"]}
    check("reaction parts", sorted(ra) == sorted(rb), f"{sorted(ra)} and {sorted(rb)}")
    scale = max([abs(f) for force in ra.values() for f in force] + [1e-300])
    for part in sorted(set(ra) & set(rb)):
        off = max(abs(x - y) for x, y in zip(ra[part], rb[part])) / scale
        check(f"reaction '{part}'", ra[part] == rb[part], f"{ra[part]} and {rb[part]} ({off:.1e})")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
