#!/usr/bin/env python3
"""The `pn` Mitsuba integrator against `pn render` and `volpath` on render scenes (issue 21).

    python scripts/mitsuba-integrator-bench.py [--scenes cloud,nebula] [--spp 256]
        [--points 3@16,5@32] [--out docs/mitsuba-integrator] [--pn target/release/pn]
        [--reference-dir out/race-cache]

Per scene: `pn export-mitsuba` writes the Mitsuba scene; the reference is the 4096-spp
`volpath` image that `pn race` caches (out/race-cache/<scene>-depthall-*/reference.exr;
run `pn race <scene>` first). Per solve point (order@resolution), with `--spp` samples:
- the `pn` integrator (llvm_ad_rgb), two seeds: its relative bias against the reference
  and the noise σ of that bias (module docs of python/tests/test_mitsuba_integrator.py);
  solve time and render time apart;
- pnsolver's own renderer on the same converted scene, Monte Carlo at the same spp, two
  seeds (bias, σ), and the default deterministic renderer (bias);
- volpath at the same spp (time, bias), once per scene.
Writes results.csv and results.md (with the date, the machine and this command) to --out.
"""

import argparse
import csv
import glob
import importlib.util
import json
import math
import os
import platform
import subprocess
import sys
import time
from datetime import datetime, timezone

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--scenes", default="cloud,nebula")
ap.add_argument("--spp", type=int, default=256)
ap.add_argument("--points", default="3@16,5@32")
ap.add_argument("--out", default=os.path.join(ROOT, "docs", "mitsuba-integrator"))
ap.add_argument("--pn", default=os.path.join(ROOT, "target", "release", "pn"))
ap.add_argument("--reference-dir", default=os.path.join(ROOT, "out", "race-cache"))
ap.add_argument("--work", default=os.path.join(ROOT, "out", "mitsuba-integrator"))
args = ap.parse_args()

import mitsuba as mi  # noqa: E402

exported = {}
for name in args.scenes.split(","):
    folder = os.path.join(args.work, name)
    subprocess.run([args.pn, "export-mitsuba", name, "--out", folder], check=True,
                   capture_output=True)
    spec = importlib.util.spec_from_file_location(f"scene_{name}",
                                                  os.path.join(folder, "render_mitsuba.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # selects scalar_rgb: done before our variant
    exported[name] = module

mi.set_variant("llvm_ad_rgb")
import pnsolver  # noqa: E402
import pnsolver.mitsuba  # noqa: E402

pnsolver.mitsuba.register()


def grey(image):
    a = np.asarray(image, dtype=np.float64)
    return a[..., :3].mean(axis=2) if a.ndim == 3 else a


def two_seeds(render):
    """(mean image, σ of the image mean, seconds per render) from seeds 1 and 2."""
    images, seconds = [], []
    for seed in (1, 2):
        t = time.perf_counter()
        images.append(grey(render(seed)))
        seconds.append(time.perf_counter() - t)
    a, b = images
    sigma = math.sqrt(np.sum((a - b) ** 2) / 4) / a.size
    return (a + b) / 2, sigma, float(np.median(seconds))


rows = []


def rmse(img):
    """RMSE against the reference over the reference's mean (`pn compare`'s rmse / mean)."""
    return math.sqrt(np.mean((img - ref) ** 2)) / ref.mean()


for name, module in exported.items():
    refs = glob.glob(os.path.join(args.reference_dir, f"{name}-depthall-*", "reference.exr"))
    if len(refs) != 1:
        sys.exit(f"no (or no unique) cached reference for {name} in {args.reference_dir}: "
                 f"run `pn race {name}` first")
    ref = grey(mi.Bitmap(refs[0]))
    ref_info = json.load(open(os.path.join(os.path.dirname(refs[0]), "reference.json")))
    m_ref = ref.mean()

    vp = mi.load_dict(module.scene_dict(-1))
    t = time.perf_counter()
    vp_img = grey(mi.render(vp, spp=args.spp, seed=1))
    vp_seconds = time.perf_counter() - t
    rows.append({"scene": name, "renderer": "volpath", "point": "", "spp": args.spp,
                 "rel_bias": (vp_img.mean() - m_ref) / m_ref, "sigma": "",
                 "rel_rmse": rmse(vp_img), "render_s": vp_seconds, "solve_s": ""})
    print(f"{name}: volpath {args.spp} spp {vp_seconds:.2f} s", flush=True)

    for point in args.points.split(","):
        order, res = (int(v) for v in point.split("@"))
        d = module.scene_dict(-1)
        d["integrator"] = {"type": "pn", "order": order, "resolution": res}
        scene = mi.load_dict(d)
        integrator = scene.integrator()
        t = time.perf_counter()
        integrator.prepare(scene)
        solve_s = time.perf_counter() - t
        one = grey(mi.render(scene, spp=args.spp, seed=3))
        img, sigma, render_s = two_seeds(lambda s: mi.render(scene, spp=args.spp, seed=s))
        rows.append({"scene": name, "renderer": "pn integrator", "point": point,
                     "spp": args.spp, "rel_bias": (img.mean() - m_ref) / m_ref,
                     "sigma": sigma / m_ref, "rel_rmse": rmse(one), "render_s": render_s,
                     "solve_s": solve_s})

        settings, density, albedo = pnsolver.mitsuba.scene_settings(
            vp, dict(integrator.solve_settings), sensor=vp.sensors()[0])

        def pn_render(seed, renderer="montecarlo"):
            s = json.loads(json.dumps(settings))
            s["render"] = {"renderer": renderer, "spp": args.spp, "seed": seed}
            if renderer != "montecarlo":
                s["render"] = {"renderer": renderer}
            return pnsolver.render(pnsolver.Scene(s, density=density, albedo=albedo))["image"]

        img, sigma, render_s = two_seeds(pn_render)
        rows.append({"scene": name, "renderer": "pn render (montecarlo)", "point": point,
                     "spp": args.spp, "rel_bias": (img.mean() - m_ref) / m_ref,
                     "sigma": sigma / m_ref, "rel_rmse": rmse(grey(pn_render(3))),
                     "render_s": render_s, "solve_s": ""})
        t = time.perf_counter()
        img = grey(pn_render(0, "deterministic"))
        rows.append({"scene": name, "renderer": "pn render (deterministic)", "point": point,
                     "spp": "", "rel_bias": (img.mean() - m_ref) / m_ref, "sigma": "",
                     "rel_rmse": rmse(img), "render_s": time.perf_counter() - t,
                     "solve_s": ""})
        print(f"{name}: P_{order} @ {res}³ done", flush=True)

os.makedirs(args.out, exist_ok=True)
with open(os.path.join(args.out, "results.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)


def fmt(v, spec):
    return format(v, spec) if isinstance(v, (int, float)) else str(v)


cmd = "python scripts/mitsuba-integrator-bench.py " + " ".join(sys.argv[1:])
lines = [
    f"Measured {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC on {platform.machine()} "
    f"({os.cpu_count()} cores), Mitsuba {mi.__version__} llvm_ad_rgb, pnsolver "
    f"{pnsolver.__version__}: `{cmd}`. Reference: the 4096-spp volpath image of `pn race` "
    f"(its own relative noise of the mean {ref_info['noise_rel_mean']:.1e} for the last scene). "
    "render_s: median of two renders (pn render: the whole call, solve included). rel. RMSE: "
    "one render (seed 3) against the reference, over the reference's mean; the reference's "
    f"own noise in it is about {ref_info['noise_rel_rmse']:.3f}.",
    "",
    "| scene | renderer | point | spp | rel. bias | σ of bias | rel. RMSE | render s | solve s |",
    "|---|---|---|---|---|---|---|---|---|",
]
for r in rows:
    lines.append(
        f"| {r['scene']} | {r['renderer']} | {r['point'] and 'P_' + r['point'].replace('@', ' @ ') + '³'} "
        f"| {r['spp']} | {fmt(r['rel_bias'], '+.4f')} | {fmt(r['sigma'], '.4f')} "
        f"| {fmt(r['rel_rmse'], '.4f')} | {fmt(r['render_s'], '.2f')} | {fmt(r['solve_s'], '.2f')} |")
open(os.path.join(args.out, "results.md"), "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
