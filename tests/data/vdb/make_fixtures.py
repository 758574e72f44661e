#!/usr/bin/python3
"""Writes the VDB test fixtures with Debian's OpenVDB Python bindings (python3-openvdb 10.0.1,
`apt-get install -y python3-openvdb`, run with /usr/bin/python3), and, from OpenVDB's own reading
of each written file, a dense float32 reference `.npy` (axes x, y, z over the active bounding box)
plus a JSON sidecar with the index bbox and the voxel-to-world transform."""
import json
import numpy as np
import pyopenvdb as vdb

def cloud(n):
    i = np.indices((n, n, n)).astype(np.float64)
    c = (n - 1) / 2.0
    r = np.sqrt(((i - c) ** 2).sum(0)) / (n / 2.0)
    d = np.clip(1.0 - r, 0.0, None) * (1.0 + 0.25 * np.sin(i[0]) * np.cos(0.7 * i[1]))
    return d.astype(np.float32)

def write(name, grid, half=False):
    grid.name = "density"
    if half:
        grid["is_saved_as_half_float"] = True
    vdb.write(name + ".vdb", grids=[grid])
    g = vdb.read(name + ".vdb", "density")
    lo, hi = g.evalActiveVoxelBoundingBox()
    shape = tuple(h - l + 1 for l, h in zip(lo, hi))
    a = np.zeros(shape, np.float32)
    g.copyToArray(a, ijk=lo)
    np.save(name + ".npy", a)
    t = g.transform
    meta = {"bbox_min_index": list(lo), "bbox_max_index": list(hi),
            "voxel_size": list(t.voxelSize()),
            "origin_world": list(t.indexToWorld((0, 0, 0))),
            "bbox_min_world_corner": list(t.indexToWorld(tuple(l - 0.5 for l in lo))),
            "bbox_max_world_corner": list(t.indexToWorld(tuple(h + 0.5 for h in hi)))}
    json.dump(meta, open(name + ".json", "w"), indent=1)

# 1. A 16³ cloud at index (0..15), identity transform.
g = vdb.FloatGrid(0.0)
g.copyFromArray(cloud(16), ijk=(0, 0, 0), tolerance=0.0)
write("cloud16", g)
# 2. A sparse 12³ cloud offset to index (-5, 3, 9), voxel size 0.125, translated.
g = vdb.FloatGrid(0.0)
g.copyFromArray(cloud(12), ijk=(-5, 3, 9), tolerance=0.0)
t = vdb.createLinearTransform(voxelSize=0.125)
t.translate((0.5, -1.0, 0.25))
g.transform = t
write("offset12", g)
# 3. The same 16³ cloud saved as half floats.
g = vdb.FloatGrid(0.0)
g.copyFromArray(cloud(16), ijk=(0, 0, 0), tolerance=0.0)
write("half16", g, half=True)
# 4. A wrong value type: a Vec3s grid named density.
g = vdb.Vec3SGrid()
g.copyFromArray(np.ones((4, 4, 4, 3), np.float32), ijk=(0, 0, 0), tolerance=(0.0, 0.0, 0.0))
g.name = "density"
vdb.write("vec3.vdb", grids=[g])
# 5. A truncated copy of cloud16.vdb.
b = open("cloud16.vdb", "rb").read()
open("truncated.vdb", "wb").write(b[: len(b) // 2])
# 6. Active tiles: a filled block (OpenVDB stores whole 8³ leaves of it as tiles, also at
#    negative indices), one leaf voxel inside the block that differs (that leaf is split off),
#    and one isolated voxel.
g = vdb.FloatGrid(0.0)
g.fill((-8, 0, 0), (15, 15, 15), 0.5, True)
g.getAccessor().setValueOn((-3, 2, 1), 2.0)
g.getAccessor().setValueOn((20, 3, 4), 1.0)
write("tiles", g)
# 7. Two grids and no `density`: `smoke` (the 12³ cloud at index 0) and `albedo`, active on a
#    smaller block inside it (0.9 on index (2..9)³, inactive elsewhere).
s = vdb.FloatGrid(0.0)
s.copyFromArray(cloud(12), ijk=(0, 0, 0), tolerance=0.0)
s.name = "smoke"
a = vdb.FloatGrid(0.0)
a.fill((2, 2, 2), (9, 9, 9), 0.9, True)
a.name = "albedo"
vdb.write("two_grids.vdb", grids=[s, a])
