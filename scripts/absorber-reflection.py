#!/usr/bin/env python3
"""How much light a discrete absorbing layer reflects, in the 1-D staggered P_N scheme.

In the continuous 1-D P_N equations a pure absorber of any profile reflects nothing: the
characteristic variables decouple and each one just decays (docs/vacuum.md). The staggered
discretization (even-l moments at cell centres, odd-l moments on the faces, σ on a face the
mean of its two cells, docs/design.md §3) does not keep that property: a jump of σ_t·h
between neighbouring cells reflects part of the light that reaches it, whatever N is.

This script measures it. A row of vacuum cells (σ = 0) is followed by an absorber whose
optical depth per cell σ_t·h is given cell by cell (the profile) and continues until nothing
comes back from the far end. The left face prescribes the right-going characteristic
amplitudes of the P_N streaming matrix (all one); in the vacuum the discrete solution is a
constant state, which is split into right- and left-going characteristic parts. The
reflection is sqrt(Σ|μ_k| c_k² over left-going / the same over right-going): the amplitude
ratio weighted by the flux each mode carries (its square is the reflected share of the
energy flux). Zero means reflectionless.

    python3 scripts/absorber-reflection.py            # the table of docs/vacuum.md
    python3 scripts/absorber-reflection.py --csv out.csv

Needs numpy (any of the project's venvs has it).
"""

import argparse
import csv
import sys

import numpy as np

ORDERS = (1, 3, 5, 7, 9, 15)
VACUUM_CELLS = 4
TAIL_CELLS = 60


def streaming(n):
    """The 1-D P_N streaming matrix: row l of μ·∂x in Legendre moments,
    (l+1)/(2l+1) φ_{l+1} + l/(2l+1) φ_{l−1}."""
    a = np.zeros((n + 1, n + 1))
    for l in range(n + 1):
        if l + 1 <= n:
            a[l, l + 1] = (l + 1) / (2 * l + 1)
        if l >= 1:
            a[l, l - 1] = l / (2 * l + 1)
    return a


def reflection(n, profile):
    """Reflection of the absorber `profile` (σ_t·h per cell, h = 1) behind VACUUM_CELLS
    vacuum cells, in the staggered P_n scheme (odd n)."""
    sigma = np.array([0.0] * VACUUM_CELLS + list(profile) + [profile[-1]] * TAIL_CELLS)
    a = streaming(n)
    speeds, modes = np.linalg.eig(a)
    speeds, modes = speeds.real, modes.real
    to_modes = np.linalg.inv(modes)
    even = [l for l in range(n + 1) if l % 2 == 0]
    odd = [l for l in range(n + 1) if l % 2 == 1]
    cells = len(sigma)
    ne, no = len(even), len(odd)
    unknowns = cells * ne + (cells + 1) * no

    def e(i, k):
        return i * ne + k

    def o(f, k):
        return cells * ne + f * no + k

    m = np.zeros((unknowns, unknowns))
    rhs = np.zeros(unknowns)
    row = 0
    # Even-l equations at the cell centres: differences of the odd moments on the two faces.
    for i in range(cells):
        for k, l in enumerate(even):
            for l2 in (l - 1, l + 1):
                if 0 <= l2 <= n:
                    j = odd.index(l2)
                    m[row, o(i + 1, j)] += a[l, l2]
                    m[row, o(i, j)] -= a[l, l2]
            m[row, e(i, k)] += sigma[i]
            row += 1
    # Odd-l equations on the inner faces: σ there is the mean of the two cells.
    for f in range(1, cells):
        for k, l in enumerate(odd):
            for l2 in (l - 1, l + 1):
                if 0 <= l2 <= n:
                    j = even.index(l2)
                    m[row, e(f, j)] += a[l, l2]
                    m[row, e(f - 1, j)] -= a[l, l2]
            m[row, o(f, k)] += 0.5 * (sigma[f - 1] + sigma[f])
            row += 1
    # Far end, deep in the absorber: odd moments zero (nothing reaches it).
    for k in range(no):
        m[row, o(cells, k)] = 1.0
        row += 1
    # Left face: the right-going characteristic amplitudes are prescribed.
    right = [k for k in range(n + 1) if speeds[k] > 0]
    left = [k for k in range(n + 1) if speeds[k] < 0]
    for k in right:
        for l in range(n + 1):
            col = e(0, even.index(l)) if l % 2 == 0 else o(0, odd.index(l))
            m[row, col] += to_modes[k, l]
        rhs[row] = 1.0
        row += 1
    assert row == unknowns
    u = np.linalg.solve(m, rhs)
    state = np.zeros(n + 1)
    for k, l in enumerate(even):
        state[l] = u[e(1, k)]
    for k, l in enumerate(odd):
        state[l] = u[o(1, k)]
    c = to_modes @ state
    back = sum(abs(speeds[k]) * c[k] ** 2 for k in left)
    forth = sum(abs(speeds[k]) * c[k] ** 2 for k in right)
    return float(np.sqrt(back / forth))


def quadratic_ramp(cells, depth=3.0):
    """The hull absorber's profile (render::hull_absorber): cell centres δ = 0.5, 1.5, …
    cells outside, σ_t·h = min(1, δ/cells)²·depth."""
    return [depth * min(1.0, (d + 0.5) / cells) ** 2 for d in range(int(np.ceil(cells)) + 1)]


PROFILES = {
    "jump to 1": [1.0],
    "jump to 3": [3.0],
    "jump to 10": [10.0],
    "ramp 1 cell (default)": quadratic_ramp(1),
    "ramp 2 cells": quadratic_ramp(2),
    "ramp 4 cells": quadratic_ramp(4),
    "ramp 8 cells": quadratic_ramp(8),
    "ramp 16 cells": quadratic_ramp(16),
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--csv", help="also write the table as CSV")
    args = parser.parse_args()
    rows = []
    for name, profile in PROFILES.items():
        rows.append([name] + [reflection(n, profile) for n in ORDERS])
    header = ["profile (σ_t·h per cell)"] + [f"P_{n}" for n in ORDERS]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for r in rows:
        print(f"| {r[0]} | " + " | ".join(f"{v:.3f}" for v in r[1:]) + " |")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["profile"] + [f"p{n}" for n in ORDERS])
            for r in rows:
                w.writerow([r[0]] + [f"{v:.6f}" for v in r[1:]])
    return 0


if __name__ == "__main__":
    sys.exit(main())
