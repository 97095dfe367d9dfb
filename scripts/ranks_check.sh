#!/usr/bin/env bash
# Runs cases on 1-4 MPI ranks and compares each with the one-rank run
# (scripts/compare_ranks.py). Needs a build with the mpi feature:
#   cargo build --release --features mpi
#   scripts/ranks_check.sh [OUT]   (default OUT: out/ranks)
# The cases and levels are those of docs/distributed.md.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${1:-out/ranks}"
BIN=target/release/cgfem-gpu
CASES=("sphere.toml 5" "sphere_q2.toml 4" "bracket.toml 5" "plate_holes.toml 5")
status=0
for entry in "${CASES[@]}"; do
  read -r file level <<<"$entry"
  name="${file%.toml}"
  common=(run "cases/$file" --level "$level" --backend cpu -q --output none)
  "$BIN" "${common[@]}" --out "$OUT/$name/1" >/dev/null
  for p in 2 3 4; do
    /usr/bin/time -f "$name L$level P=$p: %e s wall, %M kB peak (largest rank)" \
      mpirun --allow-run-as-root --oversubscribe -n "$p" "$BIN" "${common[@]}" \
      --out "$OUT/$name/$p" >/dev/null
    echo "== $name L$level, $p ranks against one"
    python3 scripts/compare_ranks.py "$OUT/$name/1/report.json" "$OUT/$name/$p/report.json" \
      | grep -v '^ok   cells' || status=1
  done
done
exit $status
