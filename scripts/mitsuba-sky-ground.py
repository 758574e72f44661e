#!/usr/bin/env python3
"""The `pn` Mitsuba integrator on a sun, a sky and a ground against `volpath` (issue 50).

    python scripts/mitsuba-sky-ground.py [--size 64] [--spp 4096] [--sky constant,envmap]
        [--threads 2]

The scene of python/tests/test_mitsuba_sky.py (the 16³ medium, σ_t scale 8, albedo 0.9,
HG 0.5, a sun, a diffuse ground disk of reflectance 0.5, the constant or the envmap sky),
rendered at --size² pixels by volpath (max_depth −1) and by the pn integrator (P_3 on a 16³
solve grid), both at --spp samples per pixel, one seed each (times include pn's solve and
Dr.Jit's compilation). Also: pn without the ground's light in
the medium (`surface_light = false`) and volpath over a black ground, to state what the
ground's light does. Prints a Markdown table with the date, the machine and the command.
Needs Mitsuba 3 with its llvm variant (DRJIT_LIBLLVM_PATH where libLLVM is not found).
"""

import argparse
import os
import platform
import sys
import time
from datetime import datetime, timezone

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python", "tests"))

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--size", type=int, default=64)
ap.add_argument("--spp", type=int, default=4096)
ap.add_argument("--sky", default="constant,envmap")
ap.add_argument("--threads", type=int, default=2)
args = ap.parse_args()

import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")
import pnsolver.mitsuba as pm  # noqa: E402

pm.register()
from test_mitsuba_sky import _sky, sky_scene  # noqa: E402


def timed(scene, spp, seed=1):
    t = time.perf_counter()
    img = np.asarray(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
    return img.mean(), time.perf_counter() - t


pn = {"type": "pn", "order": 3, "resolution": 16, "threads": args.threads}
rows = []
for sky in args.sky.split(","):
    make = lambda i, ground=0.5: sky_scene(i, _sky(sky), ground=ground, size=args.size)  # noqa: E731
    ref, t_ref = timed(make({"type": "volpath", "max_depth": -1}), args.spp)
    ours, t_pn = timed(make(pn), args.spp)
    ours64, t_pn64 = timed(make(pn), 64)
    dark, _ = timed(make({**pn, "surface_light": False}), 256)
    black, _ = timed(make({"type": "volpath", "max_depth": -1}, ground=0.0), 1024)
    black_pn, _ = timed(make(pn, ground=0.0), 256)
    rows.append((sky, ref, t_ref, ours, t_pn, ours64, t_pn64, dark, black,
                 black_pn))
    print(rows[-1], flush=True)

now = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
print(f"\n{now}, {platform.node()}, {os.cpu_count()} cores, {platform.processor() or platform.machine()}; "
      f"`python scripts/mitsuba-sky-ground.py --size {args.size} --spp {args.spp} "
      f"--sky {args.sky} --threads {args.threads}`\n")
print(f"| sky | volpath mean ({args.spp} spp) | time | pn mean ({args.spp} spp) | time | pn − volpath "
      f"| pn at 64 spp (time) | pn without the ground's light in the medium | volpath, "
      f"black ground | pn, black ground |")
print("|---|---|---|---|---|---|---|---|---|---|")
for sky, ref, t_ref, ours, t_pn, ours64, t_pn64, dark, black, black_pn in rows:
    print(f"| {sky} | {ref:.5f} | {t_ref:.0f} s | {ours:.5f} | {t_pn:.0f} s "
          f"| {100 * (ours / ref - 1):+.2f} % | {100 * (ours64 / ref - 1):+.2f} % ({t_pn64:.1f} s) "
          f"| {100 * (dark / ref - 1):+.2f} % | {black:.5f} ({100 * (black / ref - 1):+.1f} %) "
          f"| {black_pn:.5f} ({100 * (black_pn / black - 1):+.2f} % of volpath's) |")
