"""pnsolver from Python: deterministic multiple scattering in participating media.

The library behind the `pn` command, with numpy arrays in and out:

    import numpy as np, pnsolver
    scene = pnsolver.Scene.load("cloud")            # a built-in scene or a TOML file
    out = pnsolver.render(scene)                     # out["image"]: (height, width) float32
    sol = pnsolver.solve(scene)                      # sol["moments"]: (nx, ny, nz, (N+1)**2)

    d = np.zeros((32, 32, 32)); d[8:24, 8:24, 8:24] = 1.0
    scene = pnsolver.Scene({
        "medium": {"bbox_min": [-1, -1, -1], "bbox_max": [1, 1, 1],
                   "sigma_t_scale": 10.0, "albedo": 0.9},
        "light": [{"kind": "directional", "direction": [0, -1, 0], "irradiance": 1.0}],
        "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0],
                   "fov": 40.0, "width": 64, "height": 64},
        "solve": {"method": "pn", "order": 3, "resolution": [16, 16, 16]},
    }, density=d)

`Scene(settings, density=None, albedo=None, envmap=None)` takes the TOML scene of `pn render`
as a dictionary (keys as in the README); a density array has shape (nx, ny, nz) with x the
first axis (C order, as `.npy` files) and covers medium.bbox_min..bbox_max; an envmap array
(height, width, 3) or (height, width), 2:1, row 0 = +Y as Mitsuba's envmap, is the map of the
scene's `kind = "envmap"` light (which then has no `file`). `render` returns a dict
with `image` (linear radiance; (height, width, 3) for a coloured scene), the solution and
`report`; `solve` returns the solution only: `moments` (real-SH moments of the scattered
radiance at the solve-cell centres, last axis l(l+1)+m), `fluence` (sqrt(4 pi) times moment 0),
`grid_min`, `grid_max`, `grid_res`, and `report` (the report.json of `pn render`). Both release
the interpreter lock while they run; `threads=` and `progress=` are the `--threads` and
progress-bar options; `callback=f` calls f(iteration, relative_residual) for every iteration of
the P_N/CDA solve, on the calling thread while the solve runs (an exception in f ends the
call). Ctrl-C raises KeyboardInterrupt at once; the interrupted solve finishes in the
background and its result is dropped. Bad input raises ValueError with the message `pn render`
prints, naming the key, the array or the figure (docs/python.md, "Errors"). `real_sh(lmax, directions)` gives the real spherical harmonics of the moments'
convention, shape (n, (lmax+1)**2).

Phase functions are dictionaries with the keys of the scene format's `[phase]` table:
{"kind": "isotropic"}, {"kind": "hg", "g": 0.8}, {"kind": "two_term_hg", "g1": 0.9,
"g2": -0.3, "weight": 0.2} (weight: the second lobe's share), {"kind": "tabulated",
"values": v} (v over cos theta from -1 to 1 on a regular grid, or at the cosines
"cos_theta": c, strictly increasing from -1 to 1; numpy arrays allowed; normalised) and
{"kind": "droplet", "diameter": 10} (Jendersie & d'Eon's cloud-droplet phase, 5 to 50 um).
`phase_moments(phase, lmax)` gives lambda_l p_l = 2 pi int p(mu) P_l(mu) dmu for
l = 0..lmax (g**l for HG), `phase_value(phase, mu)` the normalised value at the cosines mu
(mu = 1: forward), `mitsuba_phase_dict(phase)` the Mitsuba 3 dictionary `pn export-mitsuba`
writes for it.

`pnsolver.mitsuba` (needs Mitsuba 3: `pip install ".[mitsuba]"`) is the Mitsuba integrator
`pn`: `pnsolver.mitsuba.register()`, then `{"type": "pn", "order": 3, ...}` in a scene.
"""

from ._pnsolver import (
    Scene,
    __version__,
    builtin_scenes,
    mitsuba_phase_dict,
    phase_moments,
    phase_value,
    real_sh,
    render,
    solve,
)

__all__ = ["Scene", "render", "solve", "builtin_scenes", "real_sh", "phase_moments",
           "phase_value", "mitsuba_phase_dict", "__version__"]
