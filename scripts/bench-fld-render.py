#!/usr/bin/env python3
"""FLD's two solvers against CDA in render solves (docs/fld.md, "In renders").

    python3 scripts/bench-fld-render.py [--pn target/release/pn] [--rounds 3]
        [--scenes nebula,cloud,scenes/puff.toml,scenes/cumulus.toml] [--out out/fld-render]

Per scene and round, alternately: `pn render SCENE --method fld --set solve.fld_solver=gs`,
the same with `picard` (the default), and `--method cda`; each with --save-moments. Reports
the median solve seconds (report.json `seconds.solve`), the iterations (Gauss–Seidel sweeps,
Picard steps, CG iterations), the ratios to CDA and the largest difference between the two
FLD solutions relative to their maximum. Writes fld_render.csv to --out and prints a
Markdown table.
"""

import argparse
import csv
import json
import os
import statistics
import struct
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--pn", default=os.path.join(ROOT, "target", "release", "pn"))
ap.add_argument("--rounds", type=int, default=3)
ap.add_argument("--scenes", default="nebula,cloud,scenes/puff.toml,scenes/cumulus.toml")
ap.add_argument("--out", default=os.path.join(ROOT, "out", "fld-render"))
args = ap.parse_args()

ARMS = {
    "fld gs": ["--method", "fld", "--set", "solve.fld_solver=gs"],
    "fld picard": ["--method", "fld", "--set", "solve.fld_solver=picard"],
    "cda": ["--method", "cda"],
}


def read_npy(path):
    """A float64 .npy file's values (C order), without numpy."""
    with open(path, "rb") as f:
        if f.read(6) != b"\x93NUMPY":
            sys.exit(f"{path}: not a .npy file")
        major = f.read(2)[0]
        header_len = struct.unpack("<H" if major == 1 else "<I", f.read(2 if major == 1 else 4))[0]
        header = f.read(header_len).decode("latin1")
        if "'<f8'" not in header:
            sys.exit(f"{path}: expected float64, header {header}")
        data = f.read()
    return struct.unpack(f"<{len(data) // 8}d", data)


rows = []
for scene in args.scenes.split(","):
    name = os.path.splitext(os.path.basename(scene))[0]
    seconds = {arm: [] for arm in ARMS}
    info = {}
    for _ in range(args.rounds):
        for arm, extra in ARMS.items():
            out = os.path.join(args.out, name, arm.replace(" ", "-"))
            subprocess.run([args.pn, "render", scene, *extra, "--save-moments", "--out", out],
                           check=True, capture_output=True)
            rep = json.load(open(os.path.join(out, "report.json")))
            seconds[arm].append(rep["seconds"]["solve"])
            info[arm] = rep["solver"]
    gs = read_npy(os.path.join(args.out, name, "fld-gs", "moments.npy"))
    pc = read_npy(os.path.join(args.out, name, "fld-picard", "moments.npy"))
    diff = max(abs(a - b) for a, b in zip(gs, pc)) / max(abs(v) for v in gs)
    cda = statistics.median(seconds["cda"])
    for arm in ARMS:
        s = statistics.median(seconds[arm])
        rows.append({"scene": name, "arm": arm, "solver": info[arm]["solver"],
                     "iterations": info[arm]["iterations"],
                     "relative_residual": info[arm]["relative_residual"],
                     "solve_s_median": s, "ratio_to_cda": s / cda,
                     "fld_max_rel_diff": diff if arm.startswith("fld") else ""})
    print(f"{name} done", file=sys.stderr, flush=True)

os.makedirs(args.out, exist_ok=True)
with open(os.path.join(args.out, "fld_render.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
print("| scene | solver | iterations | solve s (median) | × CDA | max Δ between the FLD solvers |")
print("|---|---|---|---|---|---|")
for r in rows:
    diff = f"{r['fld_max_rel_diff']:.1e}" if r["fld_max_rel_diff"] != "" else ""
    print(f"| {r['scene']} | {r['solver']} | {r['iterations']} | {r['solve_s_median']:.3f} "
          f"| {r['ratio_to_cda']:.1f} | {diff} |")
