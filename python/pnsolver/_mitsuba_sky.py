"""The `pn` integrator's skies, surfaces and paths (issue 50; the integrator is
python/pnsolver/mitsuba.py, which documents what it computes).

- **Skies.** An `envmap` or `constant` emitter becomes the pn scene's sky: the map (Mitsuba's
  padded bitmap with its periodic columns stripped), `scale` and `to_world`'s rotation, or the
  constant radiance.
- **Surfaces.** Shapes other than the medium's cube (a ground plane or disk with a `diffuse`
  BSDF) are traced by Mitsuba: a camera ray that reaches one before a collision in the medium
  gets the surface's direct light by next-event estimation (shadowed by the medium by ratio
  tracking and by the surfaces), plus one bounce: a cosine-sampled ray whose first collision
  in the medium adds the light scattered there (single scattering by next-event estimation,
  multiple from the solution). A collision in the medium adds, besides the emitters' single
  scattering, that of the surfaces' direct light: a phase-sampled ray that reaches a surface
  (transmittance by ratio tracking) brings its direct light.
- **The sky in the solve.** Surfaces hide part of the sky from the medium and send their own
  light into it: the solve's sky is, per texel direction, the sky where it is seen and the
  radiance of the surface seen there from its direct light (`_SURFACE_SAMPLES` next-event
  samples, shadowed by the medium), averaged over nine points of the medium's box (the
  centre and the (¼, ¾) lattice); a constant sky becomes a 128 × 64 map. In the scalar
  variants (Python per ray) only the centre, and the surfaces black.
- **Left out**: light that reaches a surface after scattering in the medium and then enters
  the medium again (the surface's radiance in the solve and in the phase-sampled ray is
  its direct light only), and second surface bounces.
"""

from __future__ import annotations

import numpy as np

import drjit as dr
import mitsuba as mi

# Texels of the map a constant sky becomes when surfaces hide part of it.
_CONSTANT_MAP = (128, 64)
# Next-event samples per texel and point for the surfaces' radiance in the solve's sky.
_SURFACE_SAMPLES = 16


def _not(b):
    """Logical not of a mask: a Dr.Jit array (wide variants) or a Python bool (scalar)."""
    return (not b) if isinstance(b, bool) else ~b


def _rotation(emitter_params):
    m = np.array(emitter_params["to_world"].matrix, dtype=np.float64).reshape(4, 4)
    return m[:3, :3]


def envmap_texels(data) -> np.ndarray:
    """The texels (H, W, 3) of a Mitsuba `envmap`'s `data` (its bitmap padded with a copy of
    the last column before the first and of the first after the last)."""
    d = np.array(data, dtype=np.float64)
    if d.ndim != 3 or d.shape[2] < 3:
        raise ValueError(f"an envmap's data must be (height, width, 3), got shape {d.shape}")
    d = d[..., :3]
    h, w = d.shape[:2]
    if w == 2 * h + 2 and np.array_equal(d[:, 0], d[:, -2]) and np.array_equal(d[:, -1], d[:, 1]):
        return d[:, 1:-1]
    if w == 2 * h + 1 and np.array_equal(d[:, -1], d[:, 0]):
        return d[:, :-1]
    if w == 2 * h:
        return d
    raise ValueError(
        f"the envmap must be twice as wide as high (latitude-longitude), got its data "
        f"{w} x {h} (with padding)"
    )


def sky_of(scene):
    """(light dict, map or None): the scene's `envmap` or `constant` emitter as a pn sky
    light (`kind = "envmap"` with the map as an array (H, W, 3), or `kind = "constant"`),
    or (None, None) without one. Refuses more than one."""
    skies = [e for e in scene.emitters()
             if e.class_name() in ("EnvironmentMapEmitter", "ConstantBackgroundEmitter")]
    if not skies:
        return None, None
    if len(skies) > 1:
        raise ValueError(f"the pn integrator takes one envmap or constant emitter, got {len(skies)}")
    e = skies[0]
    p = mi.traverse(e)
    if e.class_name() == "ConstantBackgroundEmitter":
        r = np.array(p["radiance.value"], dtype=np.float64).ravel()
        radiance = float(r[0]) if r.size == 1 or np.all(r == r[0]) else [float(v) for v in r[:3]]
        return {"kind": "constant", "radiance": radiance}, None
    texels = envmap_texels(p["data"])
    light = {"kind": "envmap", "scale": float(np.asarray(p["scale"]).ravel()[0]),
             "to_world": [[float(v) for v in row] for row in _rotation(p)]}
    return light, np.ascontiguousarray(texels)


# --------------------------------------------------------------------------------------
# Surfaces


def surfaces_of(scene, medium_shape):
    """The shapes other than the medium's cube, checked (a `diffuse` BSDF, no emitter, no
    medium), and a Mitsuba scene of them alone for the integrator's rays (None without any)."""
    others = [s for s in scene.shapes() if s is not medium_shape]
    for s in others:
        if s.interior_medium() is not None or s.exterior_medium() is not None:
            raise ValueError(f"a surface ({s.class_name()}) may not bound a medium: the pn "
                             f"integrator takes one medium, inside its cube")
        if s.is_emitter():
            raise ValueError(f"area emitters ({s.class_name()}) are not supported by the pn "
                             f"integrator")
        bsdf = s.bsdf()
        name = bsdf.class_name() if bsdf is not None else "none"
        if name != "SmoothDiffuse":
            raise ValueError(f"a surface ({s.class_name()}) must have a 'diffuse' BSDF for the "
                             f"pn integrator, got {name}")
    if not others:
        return others, None
    d = {"type": "scene"}
    for i, s in enumerate(others):
        d[f"surface_{i}"] = s
    return others, mi.load_dict(d)


def _texel_directions(w, h, rot):
    """World looking directions (h, w, 3) of a map's texels: columns at u = (i + ½)/W, rows
    at θ = jπ/(H − 1) (pn_render::sky's convention)."""
    theta = np.linspace(0.0, np.pi, h)[:, None]
    phi = 2 * np.pi * (np.arange(w) + 0.5)[None, :] / w
    local = np.stack(np.broadcast_arrays(np.sin(theta) * np.sin(phi), np.cos(theta),
                                         -np.sin(theta) * np.cos(phi)), axis=-1)
    return local @ rot.T


def _points(lo, hi):
    """The centre of the box lo..hi and its (¼, ¾) lattice."""
    return [(lo + hi) / 2] + [lo + (hi - lo) * np.array([a, b, c])
                              for a in (0.25, 0.75) for b in (0.25, 0.75) for c in (0.25, 0.75)]


def _surface_view(scene, med, surfaces, q, dirs, light=True):
    """Per direction (n, 3) from the point q: (visible, the radiance of the surface seen
    there from its direct light, RGB (n, 3); 0 where the sky is seen). Wide variants:
    `_SURFACE_SAMPLES` next-event samples per direction; scalar, or without `light`: black
    surfaces."""
    n = len(dirs)
    if mi.variant().startswith("scalar"):
        vis = np.zeros(n)
        for i, d in enumerate(dirs):
            ray = mi.Ray3f(mi.Point3f(*map(float, q)), mi.Vector3f(*map(float, d)))
            vis[i] = 0.0 if surfaces.ray_test(ray) else 1.0
        return vis, np.zeros((n, 3))
    k = _SURFACE_SAMPLES if light else 1
    rep = np.repeat(dirs, k, axis=0).astype(np.float32)
    ray = mi.Ray3f(mi.Point3f(*[float(v) for v in q]),
                   mi.Vector3f(*[mi.Float(rep[:, a]) for a in range(3)]))
    si = surfaces.ray_intersect(ray)
    hit = si.is_valid()
    vis = 1.0 - np.array(hit, dtype=np.float64).reshape(n, k).mean(axis=1)
    if not light:
        return vis, np.zeros((n, 3))
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(0, n * k)
    L = surface_direct(scene, med, surfaces, sampler, si, hit)
    L = np.array(dr.select(hit, L, 0.0), dtype=np.float64).reshape(3, -1).T
    return vis, L.reshape(n, k, 3).mean(axis=1)


def shadowed_sky(scene, med, light, texels, surfaces, lo, hi, surface_light=True):
    """The sky the solve gets where surfaces hide part of it (module docs): (light, map)."""
    if texels is None:
        w, h = _CONSTANT_MAP
        r = light["radiance"]
        texels = np.broadcast_to(np.array(r if isinstance(r, list) else [r] * 3, dtype=np.float64),
                                 (h, w, 3))
        light = {"kind": "envmap"}
        rot = np.eye(3)
    else:
        rot = np.array(light["to_world"], dtype=np.float64)
        h, w = texels.shape[:2]
    dirs = _texel_directions(w, h, rot).reshape(-1, 3)
    pts = _points(lo, hi)
    if mi.variant().startswith("scalar"):
        pts = pts[:1]  # Python per ray: the centre only
    out = np.zeros((h * w, 3))
    for q in pts:
        vis, surface = _surface_view(scene, med, surfaces, q, dirs, surface_light)
        out += vis[:, None] * texels.reshape(-1, 3) + surface
    out = (out / len(pts)).reshape(h, w, 3)
    if not np.any(out > 0):
        raise ValueError("the surfaces hide the whole sky from the medium")
    return light, np.ascontiguousarray(out)


# --------------------------------------------------------------------------------------
# Paths: Dr.Jit loops shared by the camera rays and the surfaces' bounce


def track(med, ray, sampler, active):
    """Delta tracking of `ray` (up to ray.maxt) to its first real collision in `med`:
    (found, p, albedo)."""

    def cond(ray, active, found, p, albedo, sampler):
        return active

    def body(ray, active, found, p, albedo, sampler):
        mei = med.sample_interaction(ray, sampler.next_1d(active), 0, active)
        valid = active & mei.is_valid()
        # (The guards only keep scalar Python from dividing by zero where the value is not
        # used: a valid interaction has a positive majorant, a real one σ_t > 0.)
        majorant = dr.maximum(mei.combined_extinction[0], 1e-30)
        p_real = dr.select(valid, mei.sigma_t[0] / majorant, 0.0)
        real = valid & (sampler.next_1d(valid) < p_real)
        found = found | real
        p = dr.select(real, mei.p, p)
        albedo = dr.select(real, mei.sigma_s / dr.maximum(mei.sigma_t, 1e-30), albedo)
        active = valid & _not(real)
        ray.o = dr.select(active, mei.p, ray.o)
        ray.maxt = dr.select(active, ray.maxt - mei.t, ray.maxt)
        return ray, active, found, p, albedo, sampler

    _, _, found, p, albedo, sampler = dr.while_loop(
        state=(mi.Ray3f(ray), mi.Bool(active), mi.Bool(False), mi.Point3f(0.0),
               mi.Spectrum(0.0), sampler),
        cond=cond, body=body)
    return found, p, albedo


def transmittance(med, surfaces, shadow, sampler, active):
    """Ratio tracking of `shadow` through `med`, 0 where a surface blocks it."""

    def cond(shadow, active, tr, sampler):
        return active

    def body(shadow, active, tr, sampler):
        m = med.sample_interaction(shadow, sampler.next_1d(active), 0, active)
        valid = active & m.is_valid()
        majorant = dr.maximum(m.combined_extinction[0], 1e-30)
        tr = dr.select(valid, tr * m.sigma_n[0] / majorant, tr)
        shadow.o = dr.select(valid, m.p, shadow.o)
        shadow.maxt = dr.select(valid, shadow.maxt - m.t, shadow.maxt)
        return shadow, valid, tr, sampler

    tr = mi.Float(1.0)
    if surfaces is not None:
        tr = dr.select(surfaces.ray_test(shadow, active), 0.0, tr)
    _, _, tr, sampler = dr.while_loop(
        state=(mi.Ray3f(shadow), mi.Bool(active), tr, sampler), cond=cond, body=body)
    return tr


def surface_direct(scene, med, surfaces, sampler, si, active):
    """The radiance a diffuse surface sends back along si.wi from its direct light: next-event
    estimation (one emitter), shadowed by the medium (ratio tracking) and the surfaces."""
    ds, em = scene.sample_emitter_direction(si, sampler.next_2d(active), False, active)
    go = active & (ds.pdf > 0)
    shadow = si.spawn_ray(ds.d)
    shadow.maxt = ds.dist
    tr = transmittance(med, surfaces, shadow, sampler, go)
    f = si.bsdf().eval(mi.BSDFContext(), si, si.to_local(ds.d), go)
    return dr.select(go, em * f * tr, 0.0)


def at_collision(scene, med, surfaces, sol, sampler, p, wo, time, wavelengths, found,
                 surface_light=True):
    """The in-scattered radiance at a collision p seen from direction wo (pointing back
    along the path), before the albedo: single scattering by next-event estimation (one
    emitter, as volpath) plus the solution's multiple scattering; with surfaces and
    `surface_light`, also the single scattering of the surfaces' direct light (a
    phase-sampled ray to a surface, `surface_direct` there)."""
    mei = dr.zeros(mi.MediumInteraction3f)
    mei.p = p
    mei.wi = wo
    mei.sh_frame = mi.Frame3f(wo)
    mei.t = 0.0
    mei.time = time
    mei.wavelengths = wavelengths
    ds, em = scene.sample_emitter_direction(mei, sampler.next_2d(found), False, found)
    go = found & (ds.pdf > 0)
    shadow = mi.Ray3f(p, ds.d)
    shadow.maxt = ds.dist
    shadow.time = time
    tr = transmittance(med, surfaces, shadow, sampler, go)
    ctx = mi.PhaseFunctionContext(sampler)
    phase_val, _ = med.phase_function().eval_pdf(ctx, mei, ds.d, go)
    single = em * tr * phase_val
    ms = sol.inscatter(p, wo)
    multiple = mi.Spectrum(ms[0]) if len(ms) == 1 else mi.Spectrum(ms[0], ms[1], ms[2])
    out = dr.select(go, single, 0.0) + multiple
    if surfaces is not None and surface_light:
        # The phase function's sampling weight is 1 (isotropic, hg, tabphase, blendphase).
        ps, w, _ = med.phase_function().sample(ctx, mei, sampler.next_1d(found),
                                               sampler.next_2d(found), found)
        ray = mi.Ray3f(p, ps)
        ray.time = time
        si = surfaces.ray_intersect(ray, found)
        on = found & si.is_valid()
        ray.maxt = dr.select(on, si.t, ray.maxt)
        tr = transmittance(med, None, ray, sampler, on)
        if not isinstance(on, bool) or on:
            out += dr.select(on, w * tr * surface_direct(scene, med, surfaces, sampler, si, on),
                             0.0)
    return out


def sky_seen(scene, d, active):
    """The sky's radiance towards the looking direction `d` (0 without a sky)."""
    env = scene.environment()
    if env is None:
        return mi.Spectrum(0.0)
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = -d
    return dr.select(active, env.eval(si, active), 0.0)


def at_surface(scene, med, surfaces, sol, sampler, si, time, active):
    """The radiance a diffuse surface sends back along si.wi (module docs): its direct light
    by next-event estimation, shadowed by the medium and the surfaces, plus one bounce whose
    first collision in the medium adds the light scattered there."""
    direct = surface_direct(scene, med, surfaces, sampler, si, active)
    bs, weight = si.bsdf().sample(mi.BSDFContext(), si, sampler.next_1d(active),
                                  sampler.next_2d(active), active)
    bounce = si.spawn_ray(si.to_world(bs.wo))
    bounce.time = time
    go2 = active & (bs.pdf > 0)
    hit = surfaces.ray_intersect(bounce, go2)
    bounce.maxt = dr.select(hit.is_valid(), hit.t, bounce.maxt)
    found, p, albedo = track(med, bounce, sampler, go2)
    scattered = albedo * at_collision(scene, med, surfaces, sol, sampler, p, -bounce.d, time,
                                      si.wavelengths, found, surface_light=False)
    return direct + dr.select(found, weight * scattered, 0.0)
