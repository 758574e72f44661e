#!/usr/bin/env python3
"""Two `pn` binaries on the same `pn render` commands, alternately, with the phase times.

A change to the render pipeline (shadow maps, solver, renderer) is judged by the whole
command's wall time, measured side by side with the binary before it: each round runs every
scene with binary A, then with binary B (the order alternating between rounds), so that both
see the same machine load. Prints one line per run (wall seconds and the phases of
`report.json`: density, light_depth, sources, solve, render; solver iterations; `shadow_maps` in
reports before 2026-12-05) and per
scene the medians and the ratio B/A, and writes them to a CSV.

Usage:
  scripts/bench-render-ab.py --a /tmp/pn-before --b target/release/pn \\
      --point p3@16 --point p5@32 --rounds 5 nebula cloud scenes/puff.toml scenes/cumulus.toml

A point is METHOD@RES as in `pn race` (cda, p1, p3, p5, fld); the images of A and B are
compared with `pn compare` in the first round (RMSE of B against A over A's image mean).
"""

import argparse
import csv
import json
import re
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PHASES = ["density", "shadow_maps", "light_depth", "sources", "solve", "render"]


def point_args(point: str) -> list:
    method, res = point.split("@")
    args = ["--solve-res", res]
    if re.fullmatch(r"p\d+", method):
        return args + ["--method", "pn", "--order", method[1:]]
    return args + ["--method", method]


def render(pn: str, scene: str, point: str, out: Path) -> dict:
    start = time.perf_counter()
    subprocess.run([pn, "render", scene, *point_args(point), "--out", str(out)], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    report = json.loads((out / "report.json").read_text())
    row = {"wall": wall, "iterations": (report.get("solver") or {}).get("iterations", "")}
    for phase in PHASES:
        row[phase] = report["seconds"].get(phase, 0.0)
    return row


def compare(pn: str, a: Path, b: Path) -> str:
    text = subprocess.run([pn, "compare", str(b / "image.exr"), str(a / "image.exr")],
                          check=True, capture_output=True, text=True).stdout
    rmse = re.search(r"^rmse\s+(\S+)", text, re.M)
    mean = re.search(r"^mean a / b\s+\S+ / (\S+)", text, re.M)
    if not (rmse and mean):
        return "?"
    return f"{float(rmse.group(1)) / float(mean.group(1)):.3e}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--a", required=True, help="the baseline pn binary")
    parser.add_argument("--b", default=str(ROOT / "target" / "release" / "pn"))
    parser.add_argument("--point", action="append", help="METHOD@RES (repeatable; p3@16)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--csv", type=Path, default=None, help="write the runs here")
    parser.add_argument("scenes", nargs="+")
    args = parser.parse_args()
    points = args.point or ["p3@16"]
    work = Path(tempfile.mkdtemp(prefix="pn-render-ab-"))
    runs = []
    for r in range(args.rounds):
        order = [("A", args.a), ("B", args.b)]
        if r % 2:
            order.reverse()
        for scene in args.scenes:
            for point in points:
                outs = {}
                for label, pn in order:
                    out = work / f"{label}-{Path(scene).stem}-{point}"
                    row = render(pn, scene, point, out)
                    outs[label] = out
                    row.update(round=r, binary=label, scene=Path(scene).stem, point=point)
                    if r == 0 and label == order[-1][0]:
                        row["image_rel_rmse_b_vs_a"] = compare(args.b, outs["A"], outs["B"])
                    runs.append(row)
                    phases = " ".join(f"{p} {row[p]:.3f}" for p in PHASES)
                    print(f"round {r} {label} {row['scene']} {point}: wall {row['wall']:.3f} s "
                          f"({phases}; {row['iterations']} it)", flush=True)
    print("\nmedians (seconds), B/A:")
    for scene in dict.fromkeys(Path(s).stem for s in args.scenes):
        for point in points:
            sel = {lab: [x for x in runs if x["scene"] == scene and x["point"] == point
                         and x["binary"] == lab] for lab in "AB"}
            med = {lab: {k: statistics.median(x[k] for x in sel[lab])
                         for k in ["wall", *PHASES]} for lab in "AB"}
            cells = " ".join(f"{k} {med['A'][k]:.3f}→{med['B'][k]:.3f}"
                             for k in ["wall", *PHASES])
            it = f"{sel['A'][0]['iterations']}→{sel['B'][0]['iterations']} it"
            img = next((x.get("image_rel_rmse_b_vs_a") for x in runs
                        if x["scene"] == scene and x["point"] == point
                        and "image_rel_rmse_b_vs_a" in x), "?")
            print(f"{scene} {point}: {cells}; {it}; wall B/A "
                  f"{med['B']['wall'] / med['A']['wall']:.3f}; image B vs A RMSE/mean {img}")
    if args.csv:
        keys = ["round", "binary", "scene", "point", "wall", *PHASES, "iterations",
                "image_rel_rmse_b_vs_a"]
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
            w.writeheader()
            w.writerows(runs)


if __name__ == "__main__":
    main()
