#!/usr/bin/env bash
# The device check: on a machine with a real GPU, the bench rows (levels 7
# and 8, GPU in f64 and f32 beside the CPU's matrix-free apply) and an
# end-to-end table for --backend gpu and --backend cpu (sphere Q1 L7, Q2 L5,
# Hertz L4, sphere Q1 L8). Items run in that order; one that would start
# past DEADLINE seconds (default 450) is listed as skipped, as is a run
# named in SKIP (e.g. SKIP="hertz-L4 sphere-L8-cpu": a run, or one backend
# of it; "bench" skips the bench).
#
#   scripts/device-check.sh [BIN] [OUT_DIR]
#
# BIN defaults to target/release/cgfem-gpu; OUT_DIR to out/device-check
# (bench.json, one folder per run, table.md). Record the output in
# docs/performance.md with the date, the device and the commit.
set -uo pipefail
BIN=${1:-target/release/cgfem-gpu}
OUT_DIR=${2:-out/device-check}
DEADLINE=${DEADLINE:-450}
THREADS=${THREADS:-$(nproc)}
START=$(date +%s)
mkdir -p "$OUT_DIR"
left() { echo $((DEADLINE - ($(date +%s) - START))); }

COMMIT=${COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo '?')}
echo "== device check $(date -u +%FT%TZ), commit $COMMIT, $THREADS threads"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null
"$BIN" info 2>&1 | grep -v XDG_RUNTIME_DIR

if [[ " ${SKIP:-} " == *" bench "* ]]; then
  echo "skipped: bench (SKIP)"
else
  echo "== bench (levels 7 and 8, no CSR)"
  timeout "$(left)" "$BIN" -q bench --backend gpu --level 7 --level 8 --threads "$THREADS" \
    --no-solve --no-csr --budget 0.5 --out "$OUT_DIR/bench" 2>&1 | grep -v XDG_RUNTIME_DIR
fi

echo "== end to end"
# name case level extra-sets...
RUNS=(
  "sphere-L7 cases/sphere.toml 7 solver.method=cg solver.preconditioner=auto"
  "sphere_q2-L5 cases/sphere_q2.toml 5 solver.preconditioner=auto"
  "hertz-L4 cases/hertz.toml 4"
  "sphere-L8 cases/sphere.toml 8 solver.method=cg solver.preconditioner=auto"
)
for spec in "${RUNS[@]}"; do
  read -r name case level sets <<<"$spec"
  for backend in gpu cpu; do
    if [[ " ${SKIP:-} " == *" $name "* || " ${SKIP:-} " == *" $name-$backend "* ]]; then
      echo "skipped: $name $backend (SKIP)"
      continue
    fi
    if [ "$(left)" -lt 20 ]; then
      echo "skipped: $name $backend (deadline)"
      continue
    fi
    args=(-q run "$case" --level "$level" --backend "$backend" --out "$OUT_DIR/$name-$backend")
    for s in $sets; do args+=(--set "$s"); done
    python3 - "$(left)" "$OUT_DIR/$name-$backend" "$BIN" "${args[@]}" <<'PY'
import json, os, subprocess, sys, time
limit, out, cmd = float(sys.argv[1]), sys.argv[2], sys.argv[3:]
t = time.time()
p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
rc, peak = "timeout", 0.0
while time.time() - t < limit:
    pid, status, usage = os.wait4(p.pid, os.WNOHANG)
    if pid:
        rc, peak = os.waitstatus_to_exitcode(status), usage.ru_maxrss / 1024
        break
    time.sleep(0.05)
else:
    p.kill()
wall = time.time() - t
try:
    r = json.load(open(out + "/report.json"))
except Exception:
    r = {}
tm, k = r.get("timings", {}), r.get("krylov", {})
errs = [(b.get("error") or {}).get("energy_relative") for b in r.get("bodies", [])]
err = " ".join(f"{e:.10e}" for e in errs if e is not None)
if "load_steps" in r:
    its = sum(sum(s.get("krylov_iterations", [])) for s in r["load_steps"])
    force = [c.get("normal_force") for c in r.get("contact", [])][-1:]
    detail = f"newton steps {len(r['load_steps'])} | its {its} | " + " | ".join(
        f"{key} {v:.2f}" for key, v in tm.items()) + f" | last normal force {force}"
else:
    detail = (f"{k.get('method', '')}+{k.get('preconditioner', '')} | its {k.get('total_iterations', '?')} | "
              + " | ".join(f"{key} {tm.get(key, 0):.2f}" for key in
                           ["krylov", "operator_and_rhs", "recovery", "output", "error_norms"])
              + f" | energy error {err}")
print(f"| {out.split('/')[-1]} | rc {rc} | {wall:.2f} s | {peak:.0f} MiB | "
      f"{r.get('backend', '?')} {r.get('precision', '')} | {detail} |", flush=True)
PY
  done
done
echo "== done in $(( $(date +%s) - START )) s"
