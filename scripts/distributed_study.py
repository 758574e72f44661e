#!/usr/bin/env python3
"""The distributed solve's measurements (issue 51, docs/distributed.md): iterations as the
processes and the grid grow, strong scaling, memory and halo bytes per process.

Usage: scripts/distributed_study.py OUT_DIR [--pn target/release/pn] [--quick]

Runs `mpirun -np K pn solve pointsource … --distributed` (pn built with
`--features distributed`) for every row of the study, keeps each run's report.json under
OUT_DIR/runs/, and writes OUT_DIR/results.csv and OUT_DIR/README.md (tables with the date,
the machine and the commands). Each run is a separate process; nothing runs in parallel.
"""
import argparse
import csv
import datetime
import json
import os
import platform
import shutil
import subprocess
import sys
import time

# (study, order, resolution, processes, preconditioner)
# processes 0: the one-process `pn solve` (its own multigrid, no MPI) beside them.
FULL = (
    [("iterations", 3, n, k, "mg") for n in (32, 64, 96) for k in (0, 1, 2, 4)]
    + [("strong", 5, 64, k, "mg") for k in (0, 1, 2)]
    + [("memory", 5, 48, k, "mg") for k in (1, 2, 4)]
    + [("preconditioners", 3, 48, 2, pc) for pc in ("mg", "gamg", "hypre", "jacobi")]
)
QUICK = [("iterations", 3, n, k, "mg") for n in (16, 24) for k in (0, 1, 2)]


def machine():
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"


def run(pn, out, study, order, res, ranks, pc):
    name = f"{study}-p{order}-{res}-{ranks}-{pc}"
    dest = os.path.join(out, "runs", name)
    shutil.rmtree(dest, ignore_errors=True)
    args = [pn, "solve", "pointsource", "--order", str(order), "--res", str(res),
            "--threads", "1", "--out", dest]
    if ranks > 0:
        cmd = ["mpirun", "--oversubscribe", "-np", str(ranks)] + args + ["--distributed", "--pc", pc]
    else:
        cmd = args
    print("+", " ".join(c if c != pn else "pn" for c in cmd if c != dest), flush=True)
    t0 = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - t0
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {p.stderr[-2000:]}")
    rep = json.load(open(os.path.join(dest, "report.json")))
    # Keep the report only (the fields are large).
    for f in os.listdir(dest):
        if f != "report.json":
            os.remove(os.path.join(dest, f))
    d = rep.get("distributed")
    ranks_ = d["ranks"] if d else [{
        "assembly_seconds": rep["seconds_assembly"], "setup_seconds": 0.0,
        "solve_seconds": rep["seconds_solve"], "communication_seconds": 0.0,
        "peak_memory_bytes": rep["peak_memory_bytes"], "owned_unknowns": rep["unknowns"],
        "ghost_unknowns": 0, "halo_bytes_per_application": 0,
        "operator_applications": rep["operator_applications"]}]
    return {
        "study": study, "order": order, "res": res,
        "processes": ranks if d else "pn solve", "pc": pc if d else "own mg",
        "procs": "x".join(map(str, d["procs"])) if d else "-",
        "ksp": d["ksp"] if d else rep["solver"],
        "unknowns": rep["unknowns"], "iterations": rep["iterations"],
        "relative_residual": rep["final_residual"],
        "wall_seconds": round(wall, 2),
        "assembly_seconds": round(max(r["assembly_seconds"] for r in ranks_), 3),
        "setup_seconds": round(max(r["setup_seconds"] for r in ranks_), 3),
        "solve_seconds": round(max(r["solve_seconds"] for r in ranks_), 3),
        "communication_seconds": round(max(r["communication_seconds"] for r in ranks_), 3),
        "peak_memory_mb_max": round(max(r["peak_memory_bytes"] for r in ranks_) / 2**20, 1),
        "peak_memory_mb_sum": round(sum(r["peak_memory_bytes"] for r in ranks_) / 2**20, 1),
        "owned_max": max(r["owned_unknowns"] for r in ranks_),
        "ghosts_max": max(r["ghost_unknowns"] for r in ranks_),
        "halo_bytes_max": max(r["halo_bytes_per_application"] for r in ranks_),
        "halo_bytes_sum": sum(r["halo_bytes_per_application"] for r in ranks_),
        "applications": ranks_[0]["operator_applications"],
        "reductions": ranks_[0].get("reductions", 0),
    }


def table(rows, cols):
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        out.append("| " + " | ".join(str(r[c]) for c in cols) + " |")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--pn", default="target/release/pn")
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    rows = [run(a.pn, a.out, *spec) for spec in (QUICK if a.quick else FULL)]
    with open(os.path.join(a.out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    studies = {}
    for r in rows:
        studies.setdefault(r["study"], []).append(r)
    cols = ["order", "res", "processes", "procs", "pc", "ksp", "unknowns", "iterations",
            "wall_seconds", "assembly_seconds", "setup_seconds", "solve_seconds", "communication_seconds", "peak_memory_mb_max",
            "peak_memory_mb_sum", "owned_max", "ghosts_max", "halo_bytes_sum"]
    text = [f"# Distributed solve: measurements of {started}", "",
            f"Machine: {machine()}. Command: `python3 scripts/distributed_study.py "
            f"{a.out}{' --quick' if a.quick else ''}` (pn built with `--features distributed`; "
            "`mpirun --oversubscribe -np K pn solve pointsource --order N --res R "
            "--distributed --pc PC --threads 1`; OpenMPI 4.1, PETSc 3.18 from Debian). "
            "Times are the slowest process's; memory is each process's peak resident set "
            "(getrusage), the largest and the sum; `pn solve` rows are the one-process solver "
            "with its own multigrid (its report's peak memory and solve seconds; setup is "
            "inside its solve time). Generated from results.csv.", ""]
    for s, rs in studies.items():
        text += [f"## {s}", "", table(rs, cols), ""]
    with open(os.path.join(a.out, "README.md"), "w") as f:
        f.write("\n".join(text))
    print(f"wrote {a.out}/results.csv and README.md")


if __name__ == "__main__":
    main()
