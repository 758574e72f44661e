#!/usr/bin/env python3
"""Mitsuba side of `pn race` (written by the pn binary next to an exported scene).

    python mitsuba_race.py check
    python mitsuba_race.py render --export DIR --spp N --seed S --max-depth D --out FILE.exr
                                  [--denoise] [--views VIEWS.json]

`render` imports DIR/render_mitsuba.py (written by `pn export-mitsuba`), builds the scene
with its scene_dict(max_depth), renders it with volpath at N spp and writes FILE.exr (RGB
float32). With --denoise the RGB float image goes through Intel Open Image Denoise (pyoidn,
filter "RT", hdr=True, quality "high", colour only: no albedo or normal AOVs) before it is
written. With --views, a JSON list of {"origin", "target", "up"} cameras, the scene is loaded
once and each camera rendered in turn to FILE with "_<k>" before the extension.

The last line printed is JSON: seconds_import, seconds_load, seconds_render (all views),
seconds_denoise, seconds_write, images, mitsuba and pyoidn versions.
"""
import argparse
import importlib.util
import json
import os
import sys
import time

T_START = time.perf_counter()

try:
    import mitsuba as mi
except ImportError:
    sys.exit("mitsuba_race.py: the Python package 'mitsuba' is not installed for "
             + sys.executable + "; run scripts/mitsuba-venv.sh and use its python")


def pyoidn_version():
    try:
        import importlib.metadata
        return importlib.metadata.version("pyoidn")
    except Exception:  # noqa: BLE001 (a version string only)
        return "unknown"


def need_pyoidn():
    try:
        import pyoidn  # noqa: F401
    except ImportError:
        sys.exit("mitsuba_race.py: the Python package 'pyoidn' (Open Image Denoise) is not "
                 "installed for " + sys.executable + "; run scripts/mitsuba-venv.sh")
    return pyoidn


def load_export(export_dir):
    path = os.path.join(export_dir, "render_mitsuba.py")
    if not os.path.isfile(path):
        sys.exit("mitsuba_race.py: " + path + " does not exist (run pn export-mitsuba)")
    spec = importlib.util.spec_from_file_location("render_mitsuba_export", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def view_path(out, k):
    stem, ext = os.path.splitext(out)
    return "%s_%03d%s" % (stem, k, ext)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("check")
    r = sub.add_parser("render")
    r.add_argument("--export", required=True)
    r.add_argument("--spp", type=int, required=True)
    r.add_argument("--seed", type=int, default=1)
    r.add_argument("--max-depth", type=int, default=-1)
    r.add_argument("--out", required=True)
    r.add_argument("--denoise", action="store_true")
    r.add_argument("--views")
    args = ap.parse_args()

    mi.set_variant("scalar_rgb")
    if args.cmd == "check":
        pyoidn = need_pyoidn()
        import numpy as np
        img = np.full((4, 4, 3), 0.5, dtype=np.float32)
        pyoidn.denoise(img, hdr=True)
        print(json.dumps({"mitsuba": mi.__version__, "pyoidn": pyoidn_version()}))
        return

    if args.spp < 1:
        sys.exit("mitsuba_race.py: --spp must be at least 1")
    import numpy as np
    pyoidn = need_pyoidn() if args.denoise else None
    seconds_import = time.perf_counter() - T_START

    t = time.perf_counter()
    export = load_export(args.export)
    scene_dict = export.scene_dict(args.max_depth)
    sensors = []
    outs = []
    if args.views:
        with open(args.views) as f:
            views = json.load(f)
        base = scene_dict["sensor"]
        for k, v in enumerate(views):
            s = dict(base)
            s["to_world"] = mi.ScalarTransform4f().look_at(
                origin=v["origin"], target=v["target"], up=v["up"])
            sensors.append(s)
            outs.append(view_path(args.out, k))
    scene = mi.load_dict(scene_dict)
    sensor_objs = [mi.load_dict(s) for s in sensors] or [None]
    if not outs:
        outs = [args.out]
    seconds_load = time.perf_counter() - t

    seconds_render = seconds_denoise = seconds_write = 0.0
    for sensor, out in zip(sensor_objs, outs):
        t = time.perf_counter()
        if sensor is None:
            image = mi.render(scene, spp=args.spp, seed=args.seed)
        else:
            image = mi.render(scene, sensor=sensor, spp=args.spp, seed=args.seed)
        rgb = np.array(image, dtype=np.float32)[:, :, :3]
        seconds_render += time.perf_counter() - t
        if pyoidn is not None:
            t = time.perf_counter()
            rgb = pyoidn.denoise(np.ascontiguousarray(rgb), hdr=True, quality="high")
            seconds_denoise += time.perf_counter() - t
        t = time.perf_counter()
        mi.Bitmap(np.ascontiguousarray(rgb, dtype=np.float32)).write(out)
        seconds_write += time.perf_counter() - t

    print(json.dumps({
        "seconds_import": seconds_import,
        "seconds_load": seconds_load,
        "seconds_render": seconds_render,
        "seconds_denoise": seconds_denoise,
        "seconds_write": seconds_write,
        "images": [os.path.abspath(o) for o in outs],
        "spp": args.spp, "seed": args.seed, "max_depth": args.max_depth,
        "mitsuba": mi.__version__,
        "pyoidn": pyoidn_version() if pyoidn else None,
    }))


if __name__ == "__main__":
    main()
