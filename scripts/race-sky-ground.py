#!/usr/bin/env python3
"""The race on a sun, a sky and a ground (issue 50's third scene): the `pn` Mitsuba integrator
against `volpath`, both with and without Open Image Denoise, against a volpath reference.

    python scripts/race-sky-ground.py OUT_DIR [--size 64] [--ref-spp 4096] [--sky envmap]
        [--threads 2] [--cache DIR]

The scene is python/tests/test_mitsuba_sky.py's (the 16³ medium, σ_t scale 8, albedo 0.9,
HG 0.5, a sun, a diffuse ground disk of reflectance 0.5 and the `envmap` or `constant` sky).
Mitsuba surfaces the ground in both integrators; pn's integrator (python/pnsolver/mitsuba.py)
replaces the medium's multiple scattering by the P_N solve. `pn race` cannot run this scene
(its pn side is `pn render`, which has no surfaces), so this script measures the same
quantities: the relative RMSE of the mean-of-RGB image against the reference (two halves of
`--ref-spp` each, whose difference gives the reference's own noise), the relative bias, and
the seconds of loading the scene, rendering (pn's solve included: a fresh scene per point)
and denoising. Each integrator renders once before the timed points so that Dr.Jit's kernel
compilation is not timed for either. For every pn point the Mitsuba + OIDN time at the same
error is interpolated on its (log time, log error) curve and the ratio written.

Writes OUT_DIR/points.csv and OUT_DIR/README.md (a table with the date, the machine and the
command). Needs Mitsuba 3 (llvm variant), pyoidn and pnsolver importable by this Python.
"""

import argparse
import csv
import math
import os
import platform
import sys
import time
from datetime import datetime, timezone

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python", "tests"))

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("out")
ap.add_argument("--size", type=int, default=64)
ap.add_argument("--ref-spp", type=int, default=4096)
ap.add_argument("--sky", default="envmap", choices=["envmap", "constant"])
ap.add_argument("--threads", type=int, default=2)
ap.add_argument("--cache", default=None, help="folder for the reference halves (.npy)")
args = ap.parse_args()

import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")
import pyoidn  # noqa: E402
import pnsolver.mitsuba as pm  # noqa: E402

pm.register()
from test_mitsuba_sky import _sky, sky_scene  # noqa: E402

VOLPATH = {"type": "volpath", "max_depth": -1}
MITSUBA_SPP = [1, 4, 16, 64, 256]
PN_POINTS = [(3, 16), (5, 16), (3, 24)]
PN_SPP = [1, 4, 16, 64]


def render(integrator, spp, seed=1, denoise=False):
    """(image (H, W, 3) float64, seconds of load + render (+ denoise))."""
    t = time.perf_counter()
    scene = sky_scene(integrator, _sky(args.sky), size=args.size)
    img = np.asarray(mi.render(scene, spp=spp, seed=seed), dtype=np.float32)
    if denoise:
        img = pyoidn.denoise(np.ascontiguousarray(img), hdr=True, quality="high")
    return np.asarray(img, dtype=np.float64), time.perf_counter() - t


def reference():
    """The two halves of the reference, from the cache if there."""
    tag = f"sky-ground-{args.sky}-{args.size}-{args.ref_spp}"
    paths = [os.path.join(args.cache, f"{tag}-half{k}.npy") for k in (0, 1)] if args.cache else []
    if paths and all(os.path.exists(p) for p in paths):
        return [np.load(p) for p in paths], None
    halves, secs = [], 0.0
    for k in (0, 1):
        img, s = render(VOLPATH, args.ref_spp // 2, seed=1000 + k)
        halves.append(img)
        secs += s
    if paths:
        os.makedirs(args.cache, exist_ok=True)
        for p, h in zip(paths, halves):
            np.save(p, h)
    return halves, secs


def grey(img):
    return img.mean(axis=-1)


halves, ref_seconds = reference()
ref = grey(0.5 * (halves[0] + halves[1]))
ref_norm = math.sqrt((ref ** 2).sum())
noise = math.sqrt(((grey(halves[0]) - grey(halves[1])) ** 2).sum() / 4) / ref_norm


def metrics(img):
    g = grey(img)
    return math.sqrt(((g - ref) ** 2).sum()) / ref_norm, g.mean() / ref.mean() - 1.0


pn_integrator = lambda order, res: {  # noqa: E731
    "type": "pn", "order": order, "resolution": res, "threads": args.threads}
# Dr.Jit compiles each integrator's kernels on its first render: not timed for either.
render(VOLPATH, 1)
render(pn_integrator(3, 16), 1)

rows = []
for spp in MITSUBA_SPP:
    for dn in (False, True):
        img, s = render(VOLPATH, spp, denoise=dn)
        e, b = metrics(img)
        rows.append({"tool": "mitsuba", "family": "mitsuba+oidn" if dn else "mitsuba",
                     "settings": f"spp={spp}", "spp": spp, "seconds": s, "rel_rmse": e,
                     "rel_bias": b})
        print(rows[-1], flush=True)
for order, res in PN_POINTS:
    for spp in PN_SPP:
        for dn in (False, True):
            img, s = render(pn_integrator(order, res), spp, denoise=dn)
            e, b = metrics(img)
            rows.append({"tool": "pn", "family": f"p{order}" + ("+oidn" if dn else ""),
                         "settings": f"res={res} spp={spp}", "spp": spp, "seconds": s,
                         "rel_rmse": e, "rel_bias": b})
            print(rows[-1], flush=True)


def oidn_seconds_at(err):
    """Mitsuba + OIDN's seconds at `err` on its (log s, log error) polyline; None if beyond
    its lowest error (no extrapolation)."""
    pts = sorted((r["rel_rmse"], r["seconds"]) for r in rows if r["family"] == "mitsuba+oidn")
    if err < pts[0][0]:
        return None
    if err >= pts[-1][0]:
        return min(s for _, s in pts)
    for (e0, s0), (e1, s1) in zip(pts, pts[1:]):
        if e0 <= err <= e1:
            f = (math.log(err) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(s0) + f * (math.log(s1) - math.log(s0)))
    return None


for r in rows:
    t = oidn_seconds_at(r["rel_rmse"]) if r["tool"] == "pn" else None
    r["oidn_equal_error_seconds"] = t
    r["speedup_vs_oidn"] = t / r["seconds"] if t else None

os.makedirs(args.out, exist_ok=True)
with open(os.path.join(args.out, "points.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
    w.writeheader()
    w.writerows(rows)

now = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
cmd = (f"python scripts/race-sky-ground.py {args.out} --size {args.size} --ref-spp "
       f"{args.ref_spp} --sky {args.sky} --threads {args.threads}")
fmt = lambda v, p="{:.4g}": "" if v is None else p.format(v)  # noqa: E731
lines = [
    f"# Sun, sky and ground: the pn integrator against volpath ({args.sky} sky)", "",
    f"{now}, {platform.node()}, {os.cpu_count()} cores; Mitsuba {mi.__version__} llvm_ad_rgb; "
    f"`{cmd}`. Reference: volpath {args.ref_spp} spp in two halves"
    + (f" ({ref_seconds:.0f} s)" if ref_seconds else " (cached)")
    + f", its own relative noise {noise:.4f}. Seconds: scene load + render (+ OIDN), Dr.Jit's "
    "compilation not timed. Columns as in docs/race.md.", "",
    "| tool | family | settings | seconds | rel. RMSE | rel. bias | OIDN s at this error | × vs OIDN |",
    "|---|---|---|---|---|---|---|---|",
]
for r in rows:
    lines.append(f"| {r['tool']} | {r['family']} | {r['settings']} | {r['seconds']:.3f} | "
                 f"{r['rel_rmse']:.4f} | {100 * r['rel_bias']:+.2f} % | "
                 f"{fmt(r['oidn_equal_error_seconds'], '{:.3f}')} | "
                 f"{fmt(r['speedup_vs_oidn'], '{:.2f}')} |")
best = [r for r in rows if r["tool"] == "pn" and r["speedup_vs_oidn"]
        and 0.3 <= r["seconds"] <= 10]
if best:
    b = max(best, key=lambda r: r["speedup_vs_oidn"])
    lines += ["", f"Best pn point between 0.3 and 10 s against Mitsuba + OIDN: {b['family']} "
              f"{b['settings']}, {b['rel_rmse']:.4f} in {b['seconds']:.2f} s: "
              f"**{b['speedup_vs_oidn']:.2f} ×**."]
with open(os.path.join(args.out, "README.md"), "w") as f:
    f.write("\n".join(lines) + "\n")
print("\n".join(lines))
