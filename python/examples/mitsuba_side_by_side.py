"""Render one Mitsuba 3 scene with `volpath` and with pnsolver's `pn` integrator side by side,
and print each image's error against a high-spp `volpath` reference.

    python python/examples/mitsuba_side_by_side.py [--out side_by_side.png] [--json]
        [--scene render_mitsuba.py] [--reference ref.exr] [--spp 64] [--ref-spp 1024]
        [--order 3] [--resolution 16] [--variant llvm_ad_rgb] [--width 96] [--pn-render]

Without --scene it builds a small cloud from numpy (a `gridvolume` from an array, a cube
with a null BSDF, one directional light); --scene takes a script written by
`pn export-mitsuba` (its `scene_dict(max_depth)`). --reference reads the reference image
instead of rendering it. --pn-render also renders the same scene with pnsolver's own
renderer (`pnsolver.render`, Monte Carlo at the same spp; the scene converted by
`pnsolver.mitsuba.scene_settings`) for its error beside the integrator's.

Errors, as `pn compare` computes them: rel_bias = (mean a − mean ref)/mean ref,
rel_rmse = RMSE/mean ref. Needs the package (`pip install .`), Mitsuba 3 and matplotlib; the
llvm variants need Debian's libllvm19.
"""

import argparse
import importlib.util
import json
import math
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--out", default="side_by_side.png")
ap.add_argument("--scene", help="a render_mitsuba.py written by `pn export-mitsuba`")
ap.add_argument("--reference", help="the reference image (EXR) instead of rendering it")
ap.add_argument("--spp", type=int, default=64)
ap.add_argument("--ref-spp", type=int, default=1024)
ap.add_argument("--order", type=int, default=3)
ap.add_argument("--resolution", type=int, default=16)
ap.add_argument("--variant", default="llvm_ad_rgb")
ap.add_argument("--width", type=int, default=96, help="image width and height (built-in scene)")
ap.add_argument("--threads", type=int, default=None)
ap.add_argument("--pn-render", action="store_true")
ap.add_argument("--json", action="store_true", help="print the results as one JSON line")
args = ap.parse_args()

if args.scene:
    # The exported script selects scalar_rgb when imported: load it before our variant.
    spec = importlib.util.spec_from_file_location("exported_scene", args.scene)
    exported = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(exported)

import mitsuba as mi  # noqa: E402

mi.set_variant(args.variant)
import pnsolver  # noqa: E402
import pnsolver.mitsuba  # noqa: E402

pnsolver.mitsuba.register()
T = mi.ScalarTransform4f


def numpy_cloud(n=32):
    """A soft cloud: six Gaussian bumps (seeded), thresholded."""
    x, y, z = np.meshgrid(*[np.linspace(-1, 1, n)] * 3, indexing="ij")
    rng = np.random.default_rng(7)
    bumps = sum(np.exp(-((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / (2 * 0.3 ** 2))
                for cx, cy, cz in rng.uniform(-0.4, 0.4, size=(6, 3)))
    return np.clip(bumps - 0.5, 0.0, None)


def scene_dict(integrator):
    if args.scene:
        d = exported.scene_dict(-1)
        d["integrator"] = integrator
        return d
    density = numpy_cloud()  # axes x, y, z; Mitsuba's grid is (z, y, x, channels)
    grid = mi.VolumeGrid(np.ascontiguousarray(np.transpose(density, (2, 1, 0))[..., None],
                                              dtype=np.float32))
    return {
        "type": "scene",
        "integrator": integrator,
        "medium": {"type": "heterogeneous", "id": "medium",
                   "sigma_t": {"type": "gridvolume", "grid": grid,
                               "to_world": T().translate([-1, -1, -1]).scale(2)},
                   "scale": 20.0, "albedo": 0.95, "phase": {"type": "hg", "g": 0.3}},
        "box": {"type": "cube", "bsdf": {"type": "null"},
                "interior": {"type": "ref", "id": "medium"}},
        "light": {"type": "directional", "direction": [0.5, -1.0, -0.3], "irradiance": 1.0},
        "sensor": {"type": "perspective", "fov": 40.0, "fov_axis": "x",
                   "to_world": T().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": args.width, "height": args.width,
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"}},
    }


def grey(image):
    return np.asarray(image, dtype=np.float64)[..., :3].mean(axis=2)


def timed_render(scene, spp, seed=0):
    start = time.perf_counter()
    image = grey(mi.render(scene, spp=spp, seed=seed))
    return image, time.perf_counter() - start


def errors(a, ref):
    m = ref.mean()
    return {"rel_bias": float((a.mean() - m) / m),
            "rel_rmse": float(math.sqrt(np.mean((a - ref) ** 2)) / m)}


volpath = mi.load_dict(scene_dict({"type": "volpath", "max_depth": -1}))
if args.reference:
    reference = grey(mi.Bitmap(args.reference))
    ref_seconds = None
else:
    reference, ref_seconds = timed_render(volpath, args.ref_spp, seed=12345)

pn_props = {"type": "pn", "order": args.order, "resolution": args.resolution}
if args.threads:
    pn_props["threads"] = args.threads
pn_scene = mi.load_dict(scene_dict(pn_props))
integrator = pn_scene.integrator()
start = time.perf_counter()
solution = integrator.prepare(pn_scene)
solve_seconds = time.perf_counter() - start
pn_image, pn_seconds = timed_render(pn_scene, args.spp)
vp_image, vp_seconds = timed_render(volpath, args.spp)

rows = {
    "volpath": {"spp": args.spp, "seconds": vp_seconds, **errors(vp_image, reference)},
    "pn integrator": {"spp": args.spp, "seconds": pn_seconds, "solve_seconds": solve_seconds,
                      **errors(pn_image, reference)},
}
images = [("reference", reference), (f"volpath {args.spp} spp", vp_image),
          (f"pn P_{args.order} @ {args.resolution}³, {args.spp} spp", pn_image)]
if args.pn_render:
    settings, density, albedo = pnsolver.mitsuba.scene_settings(
        volpath, dict(integrator.solve_settings), sensor=volpath.sensors()[0])
    settings["render"] = {"renderer": "montecarlo", "spp": args.spp, "seed": 1}
    start = time.perf_counter()
    out = pnsolver.render(pnsolver.Scene(settings, density=density, albedo=albedo),
                          threads=args.threads)
    img = np.asarray(out["image"], dtype=np.float64)
    img = img.mean(axis=2) if img.ndim == 3 else img
    rows["pn render"] = {"spp": args.spp, "seconds": time.perf_counter() - start,
                         **errors(img, reference)}
    images.append((f"pnsolver.render, {args.spp} spp", img))

print(f"reference: {'read from ' + args.reference if args.reference else f'volpath {args.ref_spp} spp, {ref_seconds:.2f} s'}"
      f"; variant {args.variant}; pn solve {solve_seconds:.2f} s "
      f"({solution.reports[0]['solver']['iterations'] if solution.reports and solution.reports[0].get('solver') else 0} iterations)")
print(f"{'renderer':16s} {'spp':>5s} {'seconds':>8s} {'rel_bias':>9s} {'rel_rmse':>9s}")
for name, r in rows.items():
    print(f"{name:16s} {r['spp']:5d} {r['seconds']:8.2f} {r['rel_bias']:+9.4f} {r['rel_rmse']:9.4f}")

vmax = np.percentile(reference, 99.5)
fig, axes = plt.subplots(1, len(images), figsize=(3.2 * len(images), 3.4))
for ax, (title, img) in zip(axes, images):
    ax.imshow(img, cmap="gray", vmin=0, vmax=vmax)
    ax.set_title(title, fontsize=9)
    ax.axis("off")
fig.tight_layout()
fig.savefig(args.out, dpi=100)
print(f"wrote {args.out}")
if args.json:
    print(json.dumps({"variant": args.variant, "solve_seconds": solve_seconds,
                      "reference_seconds": ref_seconds, "rows": rows}))
