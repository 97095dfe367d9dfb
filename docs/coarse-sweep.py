#!/usr/bin/env python3
"""Every shipped single-body case at the coarsest levels (1-3), Q1 and Q2,
three seeded random grid offsets each, the case's own settings otherwise;
prints the runs that did not exit 0 (exit code, seconds, the end of stderr).
Needs `cargo build --release`. Usage: docs/coarse-sweep.py [SEED]
(docs/verification.md, "Coarse grids")."""
import os, random, subprocess, sys, tempfile, time
from concurrent.futures import ThreadPoolExecutor

root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
binary = os.path.join(root, "target", "release", "cgfem-gpu")
cases = ["sphere", "sphere_q2", "torus", "bracket", "plate_with_hole",
         "shell_pressure", "cube_corner", "plate_drilled", "plate_holes"]
rng = random.Random(int(sys.argv[1]) if len(sys.argv) > 1 else 1)
jobs = [(c, level, element, [round(rng.random(), 3) for _ in range(3)])
        for c in cases for level in (1, 2, 3) for element in ("q1", "q2") for _ in range(3)]
out_root = tempfile.mkdtemp()


def run(job):
    case, level, element, offset = job
    out = os.path.join(out_root, f"{case}_{level}_{element}_{'_'.join(map(str, offset))}")
    cmd = [binary, "-q", "run", os.path.join(root, "cases", case + ".toml"),
           "--level", str(level), "--backend", "cpu",
           "--set", f'element="{element}"',
           "--set", "grid.offset=[" + ",".join(map(str, offset)) + "]", "--out", out]
    start = time.time()
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
        code, tail = p.returncode, p.stderr.strip().splitlines()[-1:]
    except subprocess.TimeoutExpired:
        code, tail = "timeout", []
    return case, level, element, offset, code, round(time.time() - start, 1), tail


with ThreadPoolExecutor(2) as pool:
    results = list(pool.map(run, jobs))
for r in results:
    if r[4] != 0:
        print(*r)
print(f"{sum(r[4] == 0 for r in results)} of {len(results)} runs exited 0")
