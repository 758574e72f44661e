#!/usr/bin/env python3
"""Writes scenes/skies/gradient-sky.exr: a 128 x 64 latitude-longitude sky (Mitsuba's envmap
convention, row 0 = +Y) whose radiance varies with elevation and azimuth: a bright horizon
band, a darker zenith, a dim ground hemisphere, and a brighter sector around azimuth
phi = 60 degrees (the side of the sun of scenes/sky-sun-envmap.toml). Grey (equal channels).

    .venv-mitsuba/bin/python scripts/make-sky-map.py   # needs numpy and mitsuba (Bitmap)
"""
import os
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
W, H = 128, 64
theta = np.linspace(0.0, np.pi, H)[:, None]          # rows at theta = j pi / (H - 1)
phi = (np.arange(W)[None, :] + 0.5) / W * 2 * np.pi  # columns at texel centres
up = np.cos(theta)
sky = np.where(up > 0, 0.35 + 0.65 * (1 - up) ** 2, 0.12 + 0.0 * up)
sector = 1.0 + 0.8 * np.exp(-((np.angle(np.exp(1j * (phi - np.pi / 3)))) ** 2) / 0.5)
lum = (sky * np.where(up > -0.05, sector, 1.0)).astype(np.float32)
img = np.repeat(lum[:, :, None], 3, axis=2)
out = os.path.join(os.path.dirname(__file__), "..", "scenes", "skies", "gradient-sky.exr")
mi.Bitmap(img).write(out)
print(out, img.shape, float(img.min()), float(img.max()))
