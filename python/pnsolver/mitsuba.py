"""pnsolver inside Mitsuba 3: the `pn` integrator.

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")          # or "scalar_rgb" (correct, but slow: Python per ray)
    import pnsolver.mitsuba
    pnsolver.mitsuba.register()             # registers the integrator type "pn"
    scene = mi.load_dict({..., "integrator": {"type": "pn", "order": 3, "resolution": 32}})
    image = mi.render(scene, spp=64)

The scene's participating medium must be one `heterogeneous` medium whose `sigma_t` is a
single-channel `gridvolume` (albedo a constant, grey or RGB, or a single-channel gridvolume of
the same resolution; phase `isotropic`, `hg`, `tabphase` or a `blendphase` of them with a
constant weight, see `phase_settings_of`), inside a `cube` shape with a `null` BSDF that
contains the grid's box; the lights are `directional` and `point` emitters and one sky, an
`envmap` or a `constant` emitter; other shapes (a ground plane or disk) with a `diffuse`
BSDF. Anything else is refused with a `ValueError` that says what is not supported.

Before the first render of a scene the integrator hands the medium and the lights to
pnsolver, which solves the multiple scattering (the moments L_l^m of the radiance scattered
at least once, docs/design.md §6). Then it renders with Mitsuba's own sampling, as
pnsolver's Monte Carlo renderer does (pn-runtime render/renderer.rs):

- the camera ray is delta-tracked through the medium (`Medium.sample_interaction`, Mitsuba's
  majorant) to its first real collision x, sampled with density T(cam, x) σ_t(x);
- there the estimate is `albedo(x) · [ E T p  +  Σ_{l,m} λ_l p_l L_l^m(x) Y_l^m(ω_o) ]`:
  single scattering by next-event estimation as `volpath` does it (one emitter sampled by
  `Scene.sample_emitter_direction`, transmittance by ratio tracking, the phase function's
  `eval_pdf`), plus the in-scattered multiple scattering read from a Dr.Jit 3D texture of
  the solution's SH coefficients (trilinear between solve-cell centres, clamped at the
  outermost centres, 0 outside the solve grid), with ω_o = −ray direction;
- and the path stops: the solution carries every higher order;
- a ray without a collision shows the sky behind the medium (as Mitsuba's `envmap` or
  `constant` emitter evaluates it; nothing with `hide_emitters`, as volpath), or the surface
  it reaches: a diffuse surface's direct light by next-event estimation (shadowed by the
  medium by ratio tracking), plus one cosine-sampled bounce whose first collision in the
  medium adds the light scattered there (single + multiple, as above).

Skies and surfaces (python/pnsolver/_mitsuba_sky.py): the sky is handed to pnsolver as the
scene's sky (`constant`, or `envmap` with its map, scale and rotation); where surfaces hide
part of it from the medium the solve's sky is, per direction, the sky where it is seen and
the surface's radiance from its direct light where a surface is seen, averaged over nine
points of the medium's box. A collision in the medium also adds the single scattering of the
surfaces' direct light (a phase-sampled ray to a surface). Left out: light that reaches the
medium after two surface reflections or after scattering, reflecting off a surface and
entering the medium again (docs/python.md gives the numbers).

Many views from one solve: the solution is kept per scene (`prepare(scene)` runs it
explicitly; `solution(scene)` returns it), so rendering other sensors of the same scene does
not solve again.

Integrator properties: `method` ("pn", "cda", "fld"; default "pn"; "none": single scattering
only), `order` (3),
`resolution` (solve cells per axis: an integer or "nx,ny,nz"; default 32), `tolerance`
(1e-4), `margin`, `absorber_width`, `absorbing_layer`, `sweeps` (the `[solve]` keys of a pn render
scene; defaults as there: 2 transport sweeps after the solve), `threads` (default: all cores),
`hide_emitters` (false: as volpath's), `surface_light` (true; false leaves the surfaces'
light out of the medium: to measure what it does). They are checked when Mitsuba creates the
integrator (types, and the ranges of a pn scene's `[solve]` table by its own check): the
ValueError reaches the user inside the RuntimeError of Mitsuba's loader.
"""

from __future__ import annotations

import math

import numpy as np

try:
    import drjit as dr
    import mitsuba as mi
except ImportError as e:  # pragma: no cover - the message is the point
    raise ImportError(
        "pnsolver.mitsuba needs Mitsuba 3 (pip install mitsuba==3.9.1): " + str(e)
    ) from e

from . import Scene, phase_moments, phase_value, solve
from ._pnsolver import _check_solve_settings
from . import _mitsuba_sky as _sky

__all__ = ["register", "integrator_class", "PnIntegrator", "Solution", "scene_settings",
           "camera_settings", "phase_settings_of", "real_sh", "scene_inputs"]


def register(name: str = "pn") -> None:
    """Registers the integrator under `name` for the current Mitsuba variant (call it again
    after `mi.set_variant` switches variants)."""
    cls = integrator_class()
    mi.register_integrator(name, lambda props: cls(props))


_CLASSES = {}


def integrator_class():
    """The integrator class of the current Mitsuba variant: [`PnIntegrator`] on that
    variant's `mi.SamplingIntegrator` (each variant has its own base class)."""
    variant = mi.variant()
    if not variant or not variant.endswith("rgb"):
        raise ValueError(
            f"the pn integrator needs an RGB variant (scalar_rgb, llvm_ad_rgb, ...), "
            f"the current one is {variant!r}"
        )
    if variant not in _CLASSES:
        # nanobind classes take one base: the methods are copied onto a subclass of it.
        methods = {k: v for k, v in vars(PnIntegrator).items()
                   if k not in ("__dict__", "__weakref__")}
        _CLASSES[variant] = type("PnIntegrator", (mi.SamplingIntegrator,), methods)
    return _CLASSES[variant]


# --------------------------------------------------------------------------------------
# Real spherical harmonics (docs/design.md §2, pn_stencil::quadrature::real_sh)


def real_sh(lmax: int, d):
    """The real spherical harmonics Y_l^m(d), l ≤ lmax, of a unit direction `d` (a Mitsuba
    Vector3f, scalar or wide), as a list indexed l(l+1)+m: the convention of
    `pn_stencil::quadrature::real_sh` (associated Legendre functions without the
    Condon–Shortley phase; cos(mφ) for m > 0, sin(|m|φ) for m < 0; orthonormal).

    Written as polynomials in (x, y, z): with s = sin θ, P_l^m(z) = s^m Q_l^m(z), and
    s^m cos(mφ), s^m sin(mφ) are the real and imaginary parts of (x + i y)^m, so no angle
    is computed."""
    x, y, z = d[0], d[1], d[2]
    out = [None] * ((lmax + 1) ** 2)
    # (x + i y)^m
    re, im = [1.0], [0.0]
    for m in range(1, lmax + 1):
        re.append(re[-1] * x - im[-1] * y)
        im.append(re[-2] * y + im[-1] * x)
    for m in range(lmax + 1):
        # Q_m^m = (2m−1)!!, Q_{m+1}^m = z (2m+1) Q_m^m, then the three-term recurrence.
        q_mm = float(np.prod(np.arange(1, 2 * m, 2))) if m > 0 else 1.0
        q_prev, q = None, q_mm
        for l in range(m, lmax + 1):
            if l == m + 1:
                q_prev, q = q, z * (2 * m + 1) * q_mm
            elif l > m + 1:
                q_prev, q = q, ((2 * l - 1) * z * q - (l + m - 1) * q_prev) / (l - m)
            ratio = 1.0
            for k in range(l - m + 1, l + m + 1):
                ratio /= k
            k_lm = math.sqrt((2 * l + 1) / (4 * math.pi) * ratio)
            if m == 0:
                out[l * (l + 1)] = k_lm * q
            else:
                c = math.sqrt(2.0) * k_lm
                out[l * (l + 1) + m] = c * q * re[m]
                out[l * (l + 1) - m] = c * q * im[m]
    return out


# --------------------------------------------------------------------------------------
# The Mitsuba scene as a pnsolver scene


def _scalar(v) -> float:
    """A Mitsuba scalar (a Python number, or a width-1 array in the wide variants)."""
    return float(np.asarray(v, dtype=np.float64).ravel()[0])


def _value(v):
    """A Mitsuba parameter value as a float or an [r, g, b] list (equal channels: a float)."""
    a = np.array(v, dtype=np.float64).ravel()
    if a.size == 1 or np.all(a == a[0]):
        return float(a[0])
    if a.size == 3:
        return [float(c) for c in a]
    raise ValueError(f"expected a number or an RGB value, got {a.size} values")


def _the_medium(scene):
    """The one heterogeneous medium and its bounding cube."""
    shapes = list(scene.shapes())
    media = [(s, s.interior_medium()) for s in shapes if s.interior_medium() is not None]
    if len(media) != 1:
        raise ValueError(
            f"the pn integrator needs exactly one shape with an interior medium, the scene has "
            f"{len(media)}"
        )
    shape, medium = media[0]
    if medium.class_name() != "HeterogeneousMedium":
        raise ValueError(
            f"the medium must be 'heterogeneous' (a gridvolume), got {medium.class_name()}"
        )
    bsdf = shape.bsdf()
    if bsdf is None or bsdf.class_name() != "Null":
        raise ValueError("the shape around the medium must have a 'null' BSDF")
    if shape.class_name() not in ("Cube", "Mesh", "PLYMesh", "OBJMesh"):
        raise ValueError(
            f"the shape around the medium must be a 'cube', got {shape.class_name()}"
        )
    return shape, medium


def _box_of_cube(shape):
    """The cube's box; refuses a rotated or non-box mesh (every vertex on a corner of its
    bounding box)."""
    bb = shape.bbox()
    lo = np.array(bb.min, dtype=np.float64)
    hi = np.array(bb.max, dtype=np.float64)
    verts = np.array(mi.traverse(shape)["vertex_positions"], dtype=np.float64).reshape(-1, 3)
    tol = 1e-5 * max(1.0, float(np.max(hi - lo)))
    on_corner = np.minimum(np.abs(verts - lo), np.abs(verts - hi)) <= tol
    if not np.all(on_corner):
        raise ValueError("the shape around the medium must be an axis-aligned box (a 'cube')")
    return lo, hi


def _grid_box(medium, hint_lo, hint_hi):
    """The world box of the medium's grid, read with `Medium.intersect_aabb` along the three
    axes through the centre of the shape's box."""
    c = (hint_lo + hint_hi) / 2
    far = 4.0 * float(np.max(hint_hi - hint_lo)) + 1.0
    lo, hi = np.zeros(3), np.zeros(3)
    for a in range(3):
        o = c.copy()
        o[a] -= far
        d = np.zeros(3)
        d[a] = 1.0
        ray = mi.Ray3f(mi.Point3f(*map(float, o)), mi.Vector3f(*map(float, d)))
        hit, t0, t1 = medium.intersect_aabb(ray)
        if _scalar(hit) == 0.0:
            raise ValueError("the medium's grid does not reach the centre of its cube")
        lo[a] = o[a] + _scalar(t0)
        hi[a] = o[a] + _scalar(t1)
    return lo, hi


def _grid_values(density, lo, hi, p, filt):
    """Mitsuba's gridvolume reading of `density` (x first) at points p (n, 3): values at the
    voxel centres, trilinear (clamped to the edge voxels in the outer half voxel) or nearest,
    0 outside the box."""
    res = np.array(density.shape)
    u = (p - lo) / (hi - lo) * res
    inside = np.all((p >= lo) & (p <= hi), axis=1)
    if filt == "nearest":
        i = np.clip(np.floor(u).astype(int), 0, res - 1)
        v = density[i[:, 0], i[:, 1], i[:, 2]]
    else:
        f = np.clip(u - 0.5, 0.0, res - 1.0)
        i0 = np.minimum(np.floor(f).astype(int), res - 1)
        i1 = np.minimum(i0 + 1, res - 1)
        w = f - i0
        v = np.zeros(len(p))
        for cx in (0, 1):
            for cy in (0, 1):
                for cz in (0, 1):
                    ix = i1[:, 0] if cx else i0[:, 0]
                    iy = i1[:, 1] if cy else i0[:, 1]
                    iz = i1[:, 2] if cz else i0[:, 2]
                    wx = w[:, 0] if cx else 1 - w[:, 0]
                    wy = w[:, 1] if cy else 1 - w[:, 1]
                    wz = w[:, 2] if cz else 1 - w[:, 2]
                    v += wx * wy * wz * density[ix, iy, iz]
    return np.where(inside, v, 0.0)


def _mitsuba_sigma_t(medium, points):
    """σ_t of the medium at `points` (n, 3), channel 0, as Mitsuba computes it."""
    out = np.zeros(len(points))
    wide = not mi.variant().startswith("scalar")
    if wide:
        mei = dr.zeros(mi.MediumInteraction3f, len(points))
        mei.p = mi.Point3f(*[mi.Float(points[:, a].astype(np.float32)) for a in range(3)])
        _, _, sigma_t = medium.get_scattering_coefficients(mei, True)
        out[:] = np.array(sigma_t[0], dtype=np.float64)
    else:
        for i, q in enumerate(points):
            mei = dr.zeros(mi.MediumInteraction3f)
            mei.p = mi.Point3f(*map(float, q))
            _, _, sigma_t = medium.get_scattering_coefficients(mei, True)
            out[i] = float(sigma_t[0])
    return out


def _filter_of(medium, density, scale, lo, hi):
    """Which filter Mitsuba's gridvolume uses, found by comparing σ_t at points inside the
    box against both readings of the grid (this also checks the box and the axis order)."""
    rng = np.random.default_rng(7)
    p = lo + (hi - lo) * rng.uniform(0.02, 0.98, size=(256, 3))
    mitsuba = _mitsuba_sigma_t(medium, p)
    size = max(1.0, float(np.max(np.abs(mitsuba))))
    for filt in ("trilinear", "nearest"):
        ours = scale * _grid_values(density, lo, hi, p, filt)
        if np.max(np.abs(ours - mitsuba)) <= 1e-4 * size:
            return filt
    raise ValueError(
        "the medium's sigma_t is not its grid read over the grid's box (a rotated or sheared "
        "gridvolume to_world is not supported)"
    )


# --------------------------------------------------------------------------------------
# The medium's phase function as a pnsolver phase dictionary


class _Children(mi.TraversalCallback):
    """The objects and values a Mitsuba object hands to `traverse`, by name (its immediate
    children only; `mi.traverse` flattens them and leaves out children without parameters,
    such as an `isotropic` phase)."""

    def __init__(self):
        mi.TraversalCallback.__init__(self)
        self.objects = {}
        self.values = {}

    def put(self, name, value, flags, cpptype=None):
        if isinstance(value, mi.Object):
            self.objects[name] = value
        else:
            self.values[name] = value

    def put_object(self, name, obj, flags):
        self.objects[name] = obj

    def put_value(self, name, value, flags, cpptype=None):
        self.values[name] = value


def _children(obj):
    cb = _Children()
    obj.traverse(cb)
    return cb.objects


def _blend_weight(volume) -> float:
    """A `blendphase` weight: a constant grey volume (`"weight": 0.3`)."""
    if volume is None or volume.class_name() != "ConstVolume":
        kind = "none" if volume is None else volume.class_name()
        raise ValueError(
            f"a blendphase weight must be a constant (a number), got a {kind}: a spatially "
            f"varying phase is not supported by the pn integrator"
        )
    w = _value(mi.traverse(volume)["value.value"])
    if isinstance(w, list):
        raise ValueError(f"a blendphase weight must be grey (one number), got {w}")
    return w


def _lobes(phase, share=1.0):
    """The phase as a list of (share, lobe) with lobe ("hg", g) or ("tab", values on the
    regular grid over cos θ ∈ [−1, 1]); `blendphase` recursively, (1 − weight) for phase1."""
    name = phase.class_name()
    if name == "IsotropicPhaseFunction":
        return [(share, ("hg", 0.0))]
    if name == "HGPhaseFunction":
        return [(share, ("hg", _scalar(mi.traverse(phase)["g"])))]
    if name == "TabulatedPhaseFunction":
        values = np.array(mi.traverse(phase)["values"], dtype=np.float64).ravel()
        return [(share, ("tab", values))]
    if name == "BlendPhaseFunction":
        c = _children(phase)
        w = _blend_weight(c.get("weight"))
        first, second = c.get("phase_0"), c.get("phase_1")
        if first is None or second is None:
            raise ValueError("a blendphase needs two nested phase functions")
        return _lobes(first, share * (1.0 - w)) + _lobes(second, share * w)
    raise ValueError(
        f"the phase function must be 'isotropic', 'hg', 'tabphase' or a 'blendphase' of "
        f"them, got {name}"
    )


# Nodes per Henyey–Greenstein lobe of a resampled blend (uniform in log(1 + g² − 2gμ): the
# relative interpolation error of HG is about (3/2 δ)²/8 with δ the step, < 3e-5 for
# |g| ≤ 0.99) and of the regular part of the grid.
_LOBE_NODES = 1025
_REGULAR_NODES = 2049


def _resampled(lobes):
    """A blend the pn phase kinds cannot name as a `tabulated` phase on irregular nodes: the
    nodes of every `tabphase` lobe (exact there: the lobe is linear between them), a regular
    grid, and per HG lobe nodes graded towards its peak."""
    nodes = [np.linspace(-1.0, 1.0, _REGULAR_NODES)]
    for _, (kind, p) in lobes:
        if kind == "tab":
            nodes.append(np.linspace(-1.0, 1.0, len(p)))
        elif abs(p) > 1e-3:
            g = p
            s = np.exp(np.linspace(math.log((1 - abs(g)) ** 2), math.log((1 + abs(g)) ** 2),
                                   _LOBE_NODES))
            nodes.append(np.clip((1 + g * g - s) / (2 * g), -1.0, 1.0))
    mu = np.unique(np.concatenate(nodes))
    mu = mu[np.concatenate(([True], np.diff(mu) > 1e-12))]
    mu[0], mu[-1] = -1.0, 1.0
    values = np.zeros_like(mu)
    for share, (kind, p) in lobes:
        # Each lobe's normalised value from pnsolver's own phase functions (a `tabphase`
        # lobe is pn's regular `tabulated` phase: linear in cos θ, normalised).
        lobe = {"kind": "hg", "g": p} if kind == "hg" else {"kind": "tabulated", "values": p}
        values += share * phase_value(lobe, mu)
    return {"kind": "tabulated", "cos_theta": mu, "values": values}


def phase_settings_of(phase) -> dict:
    """The pnsolver phase dictionary (the `[phase]` keys of a pn scene) of a Mitsuba phase
    function: `isotropic` and `hg` as they are; `tabphase` as a `tabulated` phase (its values
    on the regular grid over cos θ, the last one forward); a `blendphase` (constant weight:
    the second phase's share; nested blends too) of two `hg`/`isotropic` as `two_term_hg`,
    of one as that one, and any other blend as a `tabulated` phase on irregular nodes that
    resolve its HG peaks (`_resampled`: values within about 1e-4 of the blend's). Raises
    ValueError for other phase functions and for a varying blend weight."""
    name = phase.class_name()
    if name == "IsotropicPhaseFunction":
        return {"kind": "isotropic"}
    lobes = [(w, lobe) for w, lobe in _lobes(phase) if w > 0.0]
    if all(kind == "hg" for _, (kind, _) in lobes):
        shares = {}
        for w, (_, g) in lobes:
            shares[g] = shares.get(g, 0.0) + w
        if len(shares) == 1:
            (g,) = shares
            return {"kind": "isotropic"} if g == 0.0 else {"kind": "hg", "g": g}
        if len(shares) == 2:
            (g1, w1), (g2, w2) = shares.items()
            return {"kind": "two_term_hg", "g1": g1, "g2": g2, "weight": w2 / (w1 + w2)}
    if len(lobes) == 1:
        return {"kind": "tabulated", "values": lobes[0][1][1]}
    return _resampled(lobes)


def camera_settings(sensor):
    """The `[camera]` of a pn scene for a Mitsuba `perspective` sensor (horizontal field of
    view, the film's size; pn's pinhole camera looks along the sensor's +z with its +y up)."""
    if sensor.class_name() != "PerspectiveCamera":
        raise ValueError(f"the sensor must be 'perspective', got {sensor.class_name()}")
    p = mi.traverse(sensor)
    m = np.array(p["to_world"].matrix, dtype=np.float64).reshape(4, 4)
    origin, forward, up = m[:3, 3], m[:3, 2], m[:3, 1]
    for key in ("principal_point_offset_x", "principal_point_offset_y"):
        if key in p.keys() and _scalar(p[key]) != 0.0:
            raise ValueError(f"the sensor's {key} must be 0 for a pn camera")
    size = np.array(p["film.size"]).ravel()
    return {"position": [float(v) for v in origin],
            "target": [float(v) for v in origin + forward],
            "up": [float(v) for v in up],
            "fov": _scalar(p["x_fov"]),
            "width": int(size[0]), "height": int(size[1])}


def scene_settings(scene, solve_settings: dict | None = None, sensor=None):
    """The pnsolver scene of a Mitsuba scene: (settings dict, density array (x first),
    albedo array or None), as `pnsolver.Scene(settings, density, albedo)` takes them. The
    camera is `sensor`'s (a perspective sensor, see `camera_settings`), else a placeholder
    (solves do not use it). Raises ValueError for what the integrator does not support, and
    for a scene whose sky is a map (an `envmap`, or a sky that surfaces partly hide): use
    `scene_inputs` there."""
    inputs = scene_inputs(scene, solve_settings, sensor)
    if inputs["envmap"] is not None:
        raise ValueError("the scene's sky is a map: use scene_inputs (Scene(**inputs))")
    return inputs["settings"], inputs["density"], inputs["albedo"]


def scene_inputs(scene, solve_settings: dict | None = None, sensor=None,
                 surface_light: bool = True) -> dict:
    """The pnsolver scene of a Mitsuba scene as the keyword arguments of `pnsolver.Scene`:
    `settings`, `density` (x first), `albedo` (an array or None) and `envmap` (the sky's
    map (H, W, 3), or None). Surfaces besides the medium's cube hide part of the sky from
    the medium: the solve's sky is then shadowed (`_mitsuba_sky.shadowed_sky`). The camera is
    `sensor`'s, else a placeholder (solves do not use it). With `surface_light` the surfaces
    seen from the medium send their direct light (wide variants), else they are black."""
    shape, medium = _the_medium(scene)
    surfaces, surface_scene = _sky.surfaces_of(scene, shape)
    cube_lo, cube_hi = _box_of_cube(shape)
    params = mi.traverse(medium)
    keys = set(params.keys())
    if "sigma_t.data" not in keys:
        raise ValueError("the medium's sigma_t must be a gridvolume")
    grid = np.array(params["sigma_t.data"], dtype=np.float64)
    if grid.ndim != 4 or grid.shape[3] != 1:
        raise ValueError(
            f"the medium's sigma_t grid must have one channel (grey extinction), got shape "
            f"{grid.shape}"
        )
    density = np.ascontiguousarray(np.transpose(grid[..., 0], (2, 1, 0)))
    # Checked before the grid is compared with Mitsuba's reading of it (which a NaN spoils);
    # pnsolver checks the array again, and the albedo grid.
    bad = ~np.isfinite(density) | (density < 0)
    if np.any(bad):
        x, y, z = (int(v) for v in np.argwhere(bad)[0])
        raise ValueError(f"the medium's sigma_t grid must be finite and non-negative: voxel "
                         f"(x, y, z) = ({x}, {y}, {z}) is {density[x, y, z]}")
    scale = _scalar(params["scale"])
    if not (math.isfinite(scale) and scale >= 0):
        raise ValueError(f"the medium's scale must be finite and non-negative, got {scale}")
    lo, hi = _grid_box(medium, cube_lo, cube_hi)
    tol = 1e-5 * max(1.0, float(np.max(hi - lo)))
    if np.any(cube_lo > lo + tol) or np.any(cube_hi < hi - tol):
        raise ValueError(
            f"the cube [{cube_lo}, {cube_hi}] must contain the medium's grid [{lo}, {hi}]"
        )
    filt = _filter_of(medium, density, scale, lo, hi)

    albedo_array = None
    medium_settings = {
        "bbox_min": [float(v) for v in lo],
        "bbox_max": [float(v) for v in hi],
        "sigma_t_scale": scale,
        "filter": filt,
    }
    if "albedo.data" in keys:
        a = np.array(params["albedo.data"], dtype=np.float64)
        if a.ndim != 4 or a.shape[3] != 1:
            raise ValueError(f"an albedo grid must have one channel, got shape {a.shape}")
        albedo_array = np.ascontiguousarray(np.transpose(a[..., 0], (2, 1, 0)))
        if albedo_array.shape != density.shape:
            raise ValueError(
                f"the albedo grid {albedo_array.shape} must have the resolution of the "
                f"sigma_t grid {density.shape}"
            )
    elif "albedo.value.value" in keys:
        medium_settings["albedo"] = _value(params["albedo.value.value"])
    else:
        raise ValueError("the medium's albedo must be a constant or a gridvolume")

    phase_settings = phase_settings_of(medium.phase_function())

    lights = []
    sky, envmap = _sky.sky_of(scene)
    if sky is not None and surfaces:
        sky, envmap = _sky.shadowed_sky(scene, medium, sky, envmap, surface_scene, lo, hi,
                                          surface_light)
    for e in scene.emitters():
        p = mi.traverse(e)
        if e.class_name() in ("EnvironmentMapEmitter", "ConstantBackgroundEmitter"):
            continue
        if e.class_name() == "DirectionalEmitter":
            m = np.array(p["to_world"].matrix, dtype=np.float64).reshape(4, 4)
            d = m[:3, 2]
            lights.append({"kind": "directional", "direction": [float(v) for v in d],
                           "irradiance": _value(p["irradiance.value"])})
        elif e.class_name() == "PointLight":
            power = _value(p["intensity.value"])
            power = [4 * math.pi * v for v in power] if isinstance(power, list) else 4 * math.pi * power
            lights.append({"kind": "point",
                           "position": [float(v) for v in np.array(p["position"]).ravel()],
                           "power": power})
        else:
            raise ValueError(
                f"the pn integrator supports directional, point, envmap and constant "
                f"emitters, not {e.class_name()}"
            )
    if sky is not None:
        lights.append(sky)
    if not lights:
        raise ValueError("the scene has no directional, point, envmap or constant emitter")

    centre = (lo + hi) / 2
    extent = float(np.max(hi - lo))
    camera = {"position": [float(centre[0]), float(centre[1]), float(centre[2] + 4 * extent)],
              "target": [float(v) for v in centre], "up": [0.0, 1.0, 0.0],
              "fov": 40.0, "width": 1, "height": 1}
    settings = {
        "medium": medium_settings,
        "phase": phase_settings,
        "light": lights,
        "camera": camera if sensor is None else camera_settings(sensor),
        # Mitsuba computes the single scattering here with the true transmittance to the
        # lights, so the solve must not be delta-M truncated (pn's delta-M moves the forward
        # peak's light into a single-scattering term with σ_t − f σ_s, which Mitsuba does not
        # have; docs/design.md §6).
        "solve": {"delta_m": False, **dict(solve_settings or {})},
    }
    return {"settings": settings, "density": density, "albedo": albedo_array, "envmap": envmap}


# --------------------------------------------------------------------------------------
# The integrator


class Solution:
    """A solve of one Mitsuba scene, ready for lookups: per colour channel a Dr.Jit 3D
    texture of the moments, the solve grid's box, the phase moments λ_l p_l and the pn
    reports."""

    def __init__(self, settings, density, albedo, threads, envmap=None):
        scene = Scene(settings, density=density, albedo=albedo, envmap=envmap)
        channels = [scene.channel(c) for c in range(3)] if scene.coloured else [scene]
        self.reports = []
        self.textures = []
        self.moments = []
        for ch in channels:
            sol = solve(ch, threads=threads)
            self.reports.append(sol["report"])
            if sol["moments"] is None:
                continue
            m = np.asarray(sol["moments"])
            self.moments.append(m)
            self.grid_min = np.array(sol["grid_min"], dtype=np.float64)
            self.grid_max = np.array(sol["grid_max"], dtype=np.float64)
            # Texture3f reads a tensor (z, y, x, channel) at (u, v, w) = (x, y, z) in [0,1]³,
            # texel centres at (i + ½)/n: the solve-cell centres; clamp mode: the outermost
            # centres' values beyond them.
            t = np.ascontiguousarray(np.transpose(m, (2, 1, 0, 3)).astype(np.float32))
            self.textures.append(
                mi.Texture3f(mi.TensorXf(t), filter_mode=dr.FilterMode.Linear,
                             wrap_mode=dr.WrapMode.Clamp)
            )
        self.per_cell = self.moments[0].shape[3] if self.moments else 0
        self.lmax = int(round(math.sqrt(self.per_cell))) - 1 if self.moments else -1
        # λ_l p_l (Phase::moment) of the phase the solve used.
        self.phase_moments = [float(v) for v in phase_moments(settings["phase"], max(self.lmax, 0))]

    def inscatter(self, p, wo):
        """Σ_{l,m} λ_l p_l L_l^m(p) Y_l^m(wo) per colour channel (a list), 0 outside the
        solve grid; Mitsuba types (scalar or wide)."""
        if not self.textures:
            return [mi.Float(0.0)]
        lo = mi.Point3f(*[float(v) for v in self.grid_min])
        size = mi.Vector3f(*[float(v) for v in self.grid_max - self.grid_min])
        u = (p - lo) / size
        inside = dr.all((u >= 0) & (u <= 1))
        ylm = real_sh(self.lmax, wo)
        coeffs = []
        for l in range(self.lmax + 1):
            for m in range(-l, l + 1):
                coeffs.append(self.phase_moments[l] * ylm[l * (l + 1) + m])
        out = []
        for tex in self.textures:
            vals = tex.eval(mi.Point3f(u), active=inside)
            s = mi.Float(0.0)
            for c, v in zip(coeffs, vals):
                s += c * v
            out.append(dr.select(inside, s, 0.0))
        return out


def _integer(v) -> int:
    """An integer property value: an int, an integral float or a string of an int; otherwise
    ValueError."""
    if isinstance(v, bool):
        raise ValueError(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)) and float(v).is_integer():
        return int(v)
    if isinstance(v, str):
        return int(v.strip())
    raise ValueError(v)


def _prop(props, key, kind, default):
    """The integrator property `key` as `kind` (int, float or bool), `default` without it; a
    string spelling such a value is taken ("3", "1e-4", "true"). Anything else raises a
    ValueError naming the key (no silent int(2.5) == 2 or bool("false") == True)."""
    if key not in props:
        return default
    v = props[key]
    try:
        if kind is int:
            return _integer(v)
        if kind is float and not isinstance(v, bool):
            if isinstance(v, str):
                return float(v.strip())
            return float(v)
        if kind is bool:
            if isinstance(v, (bool, np.bool_)):
                return bool(v)
            if isinstance(v, str) and v.strip().lower() in ("true", "false"):
                return v.strip().lower() == "true"
    except (TypeError, ValueError):
        pass
    what = {int: "an integer", float: "a number", bool: "true or false"}[kind]
    raise ValueError(f"pn integrator: {key} must be {what}, got {v!r}")


class PnIntegrator:
    """Single scattering by Mitsuba's next-event estimation plus the multiple scattering of
    a pnsolver solve, at the first collision of each camera path (module docs). The methods
    of the integrator; `integrator_class()` puts them on the current variant's
    `mi.SamplingIntegrator`, and `register()` registers that class."""

    def __init__(self, props):
        type(self).__mro__[1].__init__(self, props)  # the variant's SamplingIntegrator
        solve_settings = {}
        solve_settings["method"] = str(props.get("method", "pn"))
        if solve_settings["method"] not in ("pn", "cda", "fld", "none"):
            raise ValueError(
                f"pn integrator: method must be pn, cda, fld or none, got "
                f"{solve_settings['method']!r}"
            )
        solve_settings["order"] = _prop(props, "order", int, 3)
        res = props.get("resolution", 32)
        try:
            res = ([_integer(v) for v in res.split(",")] if isinstance(res, str)
                   else [_integer(res)])
        except ValueError:
            res = []
        if len(res) not in (1, 3):
            raise ValueError(f"pn integrator: resolution must be an integer or 'nx,ny,nz', got "
                             f"{props.get('resolution')!r}")
        solve_settings["resolution"] = res * 3 if len(res) == 1 else res
        solve_settings["tolerance"] = _prop(props, "tolerance", float, 1e-4)
        for key in ("margin", "absorbing_layer", "sweeps"):
            if key in props:
                solve_settings[key] = _prop(props, key, int, None)
        if "absorber_width" in props:
            solve_settings["absorber_width"] = _prop(props, "absorber_width", float, None)
        # The checks of a scene's [solve] table, now rather than at the first render.
        try:
            _check_solve_settings(solve_settings)
        except ValueError as e:
            raise ValueError(f"pn integrator: {e}") from None
        self.solve_settings = solve_settings
        self.threads = _prop(props, "threads", int, None)
        if self.threads is not None and self.threads < 1:
            raise ValueError(f"pn integrator: threads must be at least 1, got {self.threads}")
        self.hide_emitters = _prop(props, "hide_emitters", bool, False)
        self.surface_light = _prop(props, "surface_light", bool, True)
        self._solutions = {}

    # Many views from one solve: the solution is kept per scene.
    def prepare(self, scene) -> Solution:
        """Solves the multiple scattering of `scene` (once; later calls return the kept
        solution) and returns it."""
        key = id(scene)
        if key not in self._solutions:
            inputs = scene_inputs(scene, self.solve_settings, surface_light=self.surface_light)
            shape, medium = _the_medium(scene)
            _, surfaces = _sky.surfaces_of(scene, shape)
            self._solutions[key] = (scene, medium, surfaces,
                                    Solution(**inputs, threads=self.threads))
        return self._solutions[key][3]

    def solution(self, scene) -> Solution:
        """The kept solution of `scene` (solving it first if needed)."""
        return self.prepare(scene)

    def render(self, scene, sensor=0, seed=0, spp=0, develop=True, evaluate=True):
        self.prepare(scene)
        base = type(self).__mro__[1]  # the variant's SamplingIntegrator
        return base.render(self, scene, sensor, seed, spp, develop, evaluate)

    def sample(self, scene, sampler, ray, medium=None, active=True):
        if id(scene) not in self._solutions:
            self.prepare(scene)
        _, med, surfaces, sol = self._solutions[id(scene)]
        ray = mi.Ray3f(ray)
        active = mi.Bool(active)
        hit = mi.Bool(False)
        if surfaces is not None:
            si = surfaces.ray_intersect(ray, active)
            hit = active & si.is_valid()
            ray.maxt = dr.select(hit, si.t, ray.maxt)
        # Delta tracking to the first real collision (density T σ_t along the ray), where
        # single scattering (next-event estimation) and the solution's multiple scattering
        # are added, and the path stops.
        found, p, albedo = _sky.track(med, ray, sampler, active)
        at = _sky.at_collision(scene, med, surfaces, sol, sampler, p, -ray.d, ray.time,
                               ray.wavelengths, found, self.surface_light)
        result = dr.select(found, albedo * at, 0.0)
        # No collision: the sky (unless hidden, as volpath's hide_emitters), or a surface.
        if not self.hide_emitters:
            result += _sky.sky_seen(scene, ray.d, active & _sky._not(found | hit))
        on = hit & _sky._not(found)
        if surfaces is not None and (on if isinstance(on, bool) else True):
            result += dr.select(on, _sky.at_surface(scene, med, surfaces, sol, sampler, si,
                                                    ray.time, on), 0.0)
        return result, mi.Bool(True), []

    def aov_names(self):
        return []

    def to_string(self):
        s = self.solve_settings
        return f"PnIntegrator[method={s['method']}, order={s['order']}, resolution={s['resolution']}]"
