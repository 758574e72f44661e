"""Solve the multiple scattering of a cloud made with numpy and plot a slice of its fluence.

    python python/examples/solve_numpy_cloud.py [out.png]

Needs the package (`pip install .`) and matplotlib. Prints the solver's statistics and the
fluence range; writes the figure (default: fluence_slice.png).
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pnsolver  # noqa: E402

n = 32
x, y, z = np.meshgrid(*[np.linspace(-1, 1, n)] * 3, indexing="ij")  # axes x, y, z
rng = np.random.default_rng(7)
bumps = sum(np.exp(-((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / (2 * 0.3 ** 2))
            for cx, cy, cz in rng.uniform(-0.4, 0.4, size=(6, 3)))
density = np.clip(bumps - 0.5, 0.0, None)

scene = pnsolver.Scene({
    "medium": {"bbox_min": [-1, -1, -1], "bbox_max": [1, 1, 1],
               "sigma_t_scale": 20.0, "albedo": 0.95},
    "phase": {"kind": "hg", "g": 0.3},
    "light": [{"kind": "directional", "direction": [0.5, -1.0, -0.3], "irradiance": 1.0}],
    "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0],
               "fov": 40.0, "width": 64, "height": 64},
    "solve": {"method": "pn", "order": 3, "resolution": [16, 16, 16]},
}, density=density)
sol = pnsolver.solve(scene)
s = sol["report"]["solver"]
print(f"{s['solver']}: {s['iterations']} iterations, relative residual "
      f"{s['relative_residual']:.2e}, grid {sol['grid_res']}")
phi = sol["fluence"]
print(f"fluence of the scattered light: min {phi.min():.3e}, max {phi.max():.3e}")

k = phi.shape[2] // 2
lo, hi = sol["grid_min"], sol["grid_max"]
plt.imshow(phi[:, :, k].T, origin="lower", extent=[lo[0], hi[0], lo[1], hi[1]], cmap="magma")
plt.colorbar(label="fluence φ (scattered light)")
plt.xlabel("x")
plt.ylabel("y")
plt.title(f"P_3 fluence, slice z = {lo[2] + (k + 0.5) * (hi[2] - lo[2]) / phi.shape[2]:.2f}")
out = sys.argv[1] if len(sys.argv) > 1 else "fluence_slice.png"
plt.savefig(out, dpi=100)
print("wrote", out)
