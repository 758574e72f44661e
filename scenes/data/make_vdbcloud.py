#!/usr/bin/python3
"""Writes scenes/data/vdbcloud.vdb, the density of scenes/vdbcloud.toml, with Debian's OpenVDB
Python bindings (`apt-get install -y python3-openvdb`; run with /usr/bin/python3), so that the
file comes from OpenVDB itself, not from pn.

The voxels are pn's procedural cloud of scenes/data/vdbcloud-source.toml (seed 11, 48³, box
[-1, -0.75, -1]..[1, 1.25, 1]), exported by pn as a Mitsuba .vol:

    pn export-mitsuba scenes/data/vdbcloud-source.toml --out /tmp/vdbcloud-source
    /usr/bin/python3 scenes/data/make_vdbcloud.py /tmp/vdbcloud-source/density.vol \
        scenes/data/vdbcloud.vdb

As in production files, zero voxels are inactive (`copyFromArray` with tolerance 0), so the
file's active bounding box is the cloud's, smaller than the .vol's box; the transform (voxel
size and translation) places each voxel where the .vol had it."""
import struct
import sys

import numpy as np
import pyopenvdb as vdb

src, dst = sys.argv[1], sys.argv[2]
b = open(src, "rb").read()
assert b[:3] == b"VOL" and b[3] == 3, "not a version-3 .vol file"
enc, nx, ny, nz, ch = struct.unpack("<iiiii", b[4:24])
assert enc == 1 and ch == 1, "expected one float32 channel"
lo = np.array(struct.unpack("<3f", b[24:36]), np.float64)
hi = np.array(struct.unpack("<3f", b[36:48]), np.float64)
# .vol stores x fastest; OpenVDB's array axes are (x, y, z).
d = np.frombuffer(b[48:], "<f4").reshape(nz, ny, nx).transpose(2, 1, 0).copy()
h = (hi - lo) / np.array([nx, ny, nz])
assert np.allclose(h, h[0]), "cubic voxels needed for a uniform-scale transform"
g = vdb.FloatGrid(0.0)
g.copyFromArray(d, ijk=(0, 0, 0), tolerance=0.0)
t = vdb.createLinearTransform(voxelSize=float(h[0]))
t.translate(tuple(lo + h / 2))  # voxel (0, 0, 0) is centred half a voxel inside the box
g.transform = t
g.name = "density"
vdb.write(dst, grids=[g])
print(dst, "active voxels", g.activeVoxelCount(), "of", d.size,
      "index bbox", g.evalActiveVoxelBoundingBox())
