#!/usr/bin/env bash
# Regenerates the table of docs/outer-iteration.md: every shipped linear-path
# case at the given levels, solved with the paper's fixed point
# (outer = "picard") and the outer FGMRES (outer = "fgmres", the default),
# everything else as the case file says. Needs `cargo build --release`.
# Usage: docs/outer-iteration.sh [CASE:LEVEL ...]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=target/release/cgfem-gpu
runs=("$@")
[ ${#runs[@]} -eq 0 ] && runs=(sphere:3 sphere:4 sphere:5 sphere_q2:2 sphere_q2:3 torus:3 torus:4 bracket:4 plate_with_hole:4 shell_pressure:3)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| case | level | outer | outer iterations | Krylov iterations | first solve | energy error | recovery s | Krylov s |"
echo "|---|---|---|---|---|---|---|---|---|"
for run in "${runs[@]}"; do
  case=${run%%:*}; level=${run##*:}
  for outer in picard fgmres; do
    out="$tmp/$case-$level-$outer"
    "$bin" run "cases/$case.toml" --level "$level" --out "$out" --quiet \
      --set "solver.outer=\"$outer\"" >/dev/null 2>&1 || true
    python3 - "$out/report.json" "$case" "$level" "$outer" <<'PY'
import json, sys
path, case, level, outer = sys.argv[1:]
r = json.load(open(path))
k, fp, t = r["krylov"], r["fixed_point"], r["timings"]
e = (r["bodies"][0].get("error") or {}).get("energy_relative")
first = k["iterations_per_solve"][0] if outer == "picard" else "–"
err = f"{e:.10e}" if e is not None else "–"
status = "" if r["status"] == "ok" else f" ({r['status']})"
print(f"| {case} | {level} | {outer}{status} | {fp['iterations']} | {k['total_iterations']} "
      f"| {first} | {err} | {t['recovery']:.2f} | {t['krylov']:.2f} |")
PY
  done
done
