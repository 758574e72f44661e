#!/usr/bin/env python3
"""Negative multiple-scattering fluence of render solves: P_N against filtered P_N.

For each scene and each variant, runs `pn render <scene> --save-moments` and counts the
solve cells whose zeroth moment L_0^0 (the multiple-scattering fluence / sqrt(4 pi)) is
negative, those below -1e-6 of the largest value (values of order 1e-10 of it are the
solver's tolerance in the empty absorber cells, not a property of the method), and the most
negative value relative to the largest. Prints a Markdown table
and writes a CSV (docs/pde-text.md, "Negative fluence on the render scenes").

Usage:
  scripts/negative-fluence.py [--pn target/release/pn] [--res 16 --res 32] [--csv FILE] \\
      nebula cloud scenes/puff.toml scenes/cumulus.toml

The variants: P_3, filtered P_3 (pdes/fpn.pde), P_5, filtered P_5 (pdes/fpn.pde N=5).
No numpy needed: the .npy reader below handles the little-endian float64 C-order arrays
`pn render` writes.
"""

import argparse
import ast
import csv
import struct
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VARIANTS = [
    ("P_3", ["--method", "pn", "--order", "3"]),
    ("FP_3", ["--pde", str(ROOT / "pdes" / "fpn.pde")]),
    ("P_5", ["--method", "pn", "--order", "5"]),
    ("FP_5", ["--pde", str(ROOT / "pdes" / "fpn.pde"), "--pde-param", "N=5"]),
]


def read_npy(path: Path):
    """(shape, flat values) of a little-endian float64 C-order .npy file."""
    data = path.read_bytes()
    if data[:6] != b"\x93NUMPY":
        raise SystemExit(f"{path}: not a .npy file")
    major = data[6]
    if major == 1:
        hlen = struct.unpack("<H", data[8:10])[0]
        start = 10
    else:
        hlen = struct.unpack("<I", data[8:12])[0]
        start = 12
    header = ast.literal_eval(data[start:start + hlen].decode("latin1"))
    if header["descr"] != "<f8" or header["fortran_order"]:
        raise SystemExit(f"{path}: expected little-endian float64 in C order, got {header}")
    body = data[start + hlen:]
    values = struct.unpack(f"<{len(body) // 8}d", body)
    return tuple(header["shape"]), values


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pn", default=str(ROOT / "target" / "release" / "pn"))
    parser.add_argument("--res", type=int, action="append", help="solve resolution (16)")
    parser.add_argument("--csv", type=Path, default=None)
    parser.add_argument("scenes", nargs="+")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="pn-negative-fluence-"))
    rows = []
    for scene in args.scenes:
        for res in args.res or [16]:
            for name, variant in VARIANTS:
                out = work / f"{Path(scene).stem}-{res}-{name}"
                subprocess.run([args.pn, "render", scene, *variant, "--solve-res", str(res),
                                "--save-moments", "--out", str(out)], check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                shape, values = read_npy(out / "moments.npy")
                per_cell = shape[-1]
                l0 = values[::per_cell]
                negative = [v for v in l0 if v < 0.0]
                top = max(l0)
                rows.append({
                    "scene": Path(scene).stem, "res": res, "variant": name,
                    "cells": len(l0), "negative_cells": len(negative),
                    "below_1e-6_max": sum(v < -1e-6 * top for v in negative),
                    "min_over_max": (min(negative) / top) if negative else 0.0,
                })
    print("| scene | res | variant | cells | L_0^0 < 0 | L_0^0 < −10⁻⁶·max | min / max |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scene']} | {r['res']}³ | {r['variant']} | {r['cells']} | "
              f"{r['negative_cells']} | {r['below_1e-6_max']} | {r['min_over_max']:.2e} |")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
