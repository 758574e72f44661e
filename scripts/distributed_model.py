#!/usr/bin/env python3
"""A model of the distributed solve at 256³ and 512³ P_5 on 16–256 processes, from the
per-process measurements of scripts/distributed_study.py (issue 51, docs/distributed.md).

Usage: scripts/distributed_model.py RESULTS_CSV  (prints a Markdown section)

Every constant below is either read from the CSV (and named so) or an assumption stated in
the printed text; nothing is fitted to the predicted sizes.
"""
import csv
import math
import sys

# The interconnect: InfiniBand HDR100 (100 Gb/s per port), as on many current clusters.
LINK_BYTES_PER_S = 12.5e9
LATENCY_S = 1.5e-6
P5_MOMENTS, P5_KEPT = 36, 15  # P_5: (N+1)² moments; the even-l ones (l = 0, 2, 4) kept


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def main():
    data = rows(sys.argv[1])
    dist = [r for r in data if r["processes"] != "pn solve"]
    mem = [r for r in dist if r["study"] == "memory"]
    strong = [r for r in dist if r["study"] == "strong"]
    iters = [r for r in dist if r["study"] == "iterations" and r["processes"] == "1"]
    # Memory per process = base + c·(owned unknowns): least squares over the memory rows.
    xs = [float(r["owned_max"]) for r in mem]
    ys = [float(r["peak_memory_mb_max"]) * 2**20 for r in mem]
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    c = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    base = my - c * mx
    # Compute per iteration per owned unknown, one process (no communication in it).
    s1 = next(r for r in strong if r["processes"] == "1")
    tau = float(s1["solve_seconds"]) / int(s1["iterations"]) / int(s1["owned_max"])
    apps_per_it = int(s1["applications"]) / int(s1["iterations"])
    it64 = int(s1["iterations"])
    # Iterations grow by `delta` per doubling of the resolution (P_3, 32³ → 96³, one process).
    it = {int(r["res"]): int(r["iterations"]) for r in iters}
    lo, hi = min(it), max(it)
    delta = (it[hi] - it[lo]) / math.log2(hi / lo)
    # Halo bytes per application per unit of interface area (cells²), from the 2-process split
    # of the memory study (2×1×1: one interface of res² cells).
    m2 = next(r for r in mem if r["processes"] == "2")
    res_m = int(m2["res"])
    halo_per_cell2 = int(m2["halo_bytes_sum"]) / (2 * res_m * res_m)

    out = [
        "### Model: 256³ and 512³ P_5 on 16–256 processes",
        "",
        "From the measurements above (`scripts/distributed_model.py results.csv`):",
        f"memory per process = {base / 2**20:.0f} MB + {c:.0f} bytes × owned unknowns "
        f"(least squares over the P_5 48³ memory rows); compute {tau * 1e9:.1f} ns per owned "
        f"unknown per iteration (P_5 64³, one process, {apps_per_it:.1f} applications of S "
        f"per iteration); {it64} iterations at 64³ growing by {delta:.1f} per doubling of the "
        f"resolution (P_3, {lo}³ → {hi}³); {halo_per_cell2:.0f} bytes received per "
        "application per cell² of box interface (P_5 48³ on 2×1×1).",
        "",
        "Assumptions: one process per core of this machine's speed (a full node shares its "
        "memory bandwidth among its cores, so the compute term is optimistic by the node's "
        "bandwidth per core against this VM's); cubic boxes (K a cube, else the nearest "
        "split); InfiniBand HDR100, 12.5 GB/s per process and 1.5 µs latency, 6 neighbour "
        "messages per ghost exchange and two exchanges per application, no overlap of "
        "communication with computation; two allreduces per GMRES iteration at 2·log₂K "
        "latencies each; the coarsest level (≤ 2000 unknowns, LU on every process) and the "
        "setup (assembly, PtAP) left out; process 0 also holds the gathered solution "
        "(8 bytes per unknown, not in the table).",
        "",
        "| grid | processes | owned unknowns per process | memory per process | halo per application | iterations | compute per iteration | communication per iteration | solve | efficiency |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for res in (256, 512):
        cells = res**3
        unknowns = P5_MOMENTS * cells
        iterations = it64 + delta * math.log2(res / 64)
        for k in (16, 32, 64, 128, 256):
            owned = unknowns / k
            side = res / round(k ** (1 / 3)) if round(k ** (1 / 3)) ** 3 == k else (cells / k) ** (1 / 3)
            halo = halo_per_cell2 * 6 * side * side
            comm = apps_per_it * 2 * (6 * LATENCY_S + halo / 2 / LINK_BYTES_PER_S) \
                + 2 * 2 * LATENCY_S * math.log2(k)
            compute = tau * owned
            total = iterations * (compute + comm)
            eff = compute / (compute + comm)
            memory = base + c * owned
            out.append(
                f"| {res}³ | {k} | {owned / 1e6:.1f} M | {memory / 2**30:.1f} GB | "
                f"{halo / 2**20:.1f} MB | {iterations:.0f} | {compute:.2f} s | "
                f"{comm * 1e3:.1f} ms | {total / 60:.1f} min | {eff:.1%} |"
            )
    out += [
        "",
        f"256³ P_5 has {P5_MOMENTS * 256**3 / 1e6:.0f} M unknowns ({P5_KEPT * 256**3 / 1e6:.0f} M "
        f"kept); 512³ P_5 {P5_MOMENTS * 512**3 / 1e9:.2f} G, whose {21 * 512**3 / 1e9:.2f} G "
        "eliminated unknowns exceed the 2³¹ of Debian's 32-bit PETSc indices: that size needs "
        "PETSc built with 64-bit indices.",
    ]
    print("\n".join(out))


if __name__ == "__main__":
    main()
