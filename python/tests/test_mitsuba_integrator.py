"""The Mitsuba 3 integrator `pn` (python/pnsolver/mitsuba.py) against pnsolver's own renderer,
against Mitsuba's volpath, and on input it must refuse.

Needs Mitsuba 3 in the interpreter (`pip install .[test,mitsuba]`). The llvm variant needs
Debian's libllvm19; where it cannot start the llvm tests skip, unless
PN_REQUIRE_MITSUBA_LLVM is set (CI sets it: there they must run).

Statistics: every comparison of two Monte Carlo images compares image means, each estimated
from two renders with different seeds: σ of a mean = sqrt(Σ_px (a₁ − a₂)²/4)/N_px (the
per-pixel variance of a one-seed render is E(a₁ − a₂)²/2, a mean of two renders halves it).
Two estimators of the same quantity must agree within 4.5 σ of their difference (a false
alarm about once in 150 000 runs for Gaussian means).
"""

import math
import os
import subprocess
import sys

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba") if not os.environ.get("PN_REQUIRE_MITSUBA") else __import__("mitsuba")
import drjit as dr  # noqa: E402

import pnsolver  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
N_SIGMA = 4.5


def _llvm_works():
    try:
        mi.set_variant("llvm_ad_rgb")
        x = dr.llvm.Float([1.0, 2.0]) * 2.0
        dr.eval(x)
        return float(x[1]) == 4.0
    except Exception:  # noqa: BLE001 - any failure means: no LLVM backend here
        return False


LLVM = _llvm_works()


def use(variant):
    """Selects `variant` and registers the integrator for it."""
    if variant.startswith("llvm") and not LLVM:
        if os.environ.get("PN_REQUIRE_MITSUBA_LLVM"):
            pytest.fail("the llvm variant cannot start (libLLVM missing?) and "
                        "PN_REQUIRE_MITSUBA_LLVM is set")
        pytest.skip("the llvm variant cannot start here (Debian: apt-get install libllvm19)")
    mi.set_variant(variant)
    import pnsolver.mitsuba as pm
    pm.register()
    return pm


def density():
    """A 16³ soft, asymmetric medium (a transposed axis would show)."""
    d = np.zeros((16, 16, 16))
    d[2:14, 3:15, 1:13] = 1.0
    d[5, 7, 9] = 3.0
    x = np.linspace(-1, 1, 16)
    gx, gy, gz = np.meshgrid(x, x, x, indexing="ij")
    return d * np.exp(-(gx ** 2 + 0.5 * gy ** 2 + 1.5 * gz ** 2))


def mitsuba_scene(integrator, g=0.7, albedo=0.9, light=None, size=20, extra=None, sigma_t=None,
                  phase=None):
    T = mi.ScalarTransform4f
    d = density()
    grid = sigma_t or {
        "type": "gridvolume",
        "grid": mi.VolumeGrid(np.ascontiguousarray(np.transpose(d, (2, 1, 0))[..., None],
                                                   dtype=np.float32)),
        "to_world": T().translate([-1, -1, -1]).scale(2),
    }
    if isinstance(albedo, (list, tuple)):
        albedo = {"type": "rgb", "value": list(albedo)}
    scene = {
        "type": "scene",
        "integrator": integrator,
        "medium": {"type": "heterogeneous", "id": "medium", "sigma_t": grid, "scale": 8.0,
                   "albedo": albedo, "phase": phase or {"type": "hg", "g": g}},
        "box": {"type": "cube", "bsdf": {"type": "null"},
                "interior": {"type": "ref", "id": "medium"}},
        "light": light or {"type": "directional", "direction": [0.3, -1.0, -0.2],
                           "irradiance": 1.0},
        "sensor": {"type": "perspective", "fov": 40.0, "fov_axis": "x",
                   "to_world": T().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": size, "height": size,
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"}},
    }
    scene.update(extra or {})
    return mi.load_dict(scene)


def mean_and_sigma(render, channel=None):
    """(mean, σ of the mean) of an image estimated from two seeds (module docs)."""
    a, b = (np.asarray(render(seed), dtype=np.float64) for seed in (1, 2))
    if channel is not None:
        a, b = a[..., channel], b[..., channel]
    sigma = math.sqrt(np.sum((a - b) ** 2) / 4) / a.size
    return (a.mean() + b.mean()) / 2, sigma


def agree(x, y):
    (ma, sa), (mb, sb) = x, y
    return abs(ma - mb) <= N_SIGMA * math.hypot(sa, sb), (ma, mb, (ma - mb) / math.hypot(sa, sb))


def test_the_spherical_harmonics_equal_pnsolvers():
    rng = np.random.default_rng(3)
    d = rng.normal(size=(64, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    d[0] = [0.0, 0.0, 1.0]  # the poles, where φ is undefined
    d[1] = [0.0, 0.0, -1.0]
    ref = pnsolver.real_sh(6, d)
    for variant in ("scalar_rgb", "llvm_ad_rgb"):
        if variant.startswith("llvm") and not LLVM:
            use(variant)  # fails or skips, as the module docs say
        pm = use(variant)
        if variant.startswith("scalar"):
            ours = np.array([[float(v) for v in pm.real_sh(6, mi.Vector3f(*map(float, row)))]
                             for row in d])
        else:
            v = mi.Vector3f(*[mi.Float(d[:, a].astype(np.float32)) for a in range(3)])
            ours = np.stack([np.broadcast_to(np.asarray(c, dtype=np.float64), len(d))
                             for c in pm.real_sh(6, v)], axis=1)
        # float32 arithmetic on values of order 1: 1e-5 is ~100 ulp.
        assert np.max(np.abs(ours - ref)) < 1e-5, variant


def test_the_lookup_is_pnsolvers_trilinear_read_of_the_solution():
    """Solution.inscatter equals Σ λ_l p_l L_l^m(x) Y_l^m(ω) with L read as pn's MsField
    does (trilinear between cell centres, clamped at the outermost ones, 0 outside)."""
    pm = use("llvm_ad_rgb")
    scene = mitsuba_scene({"type": "pn", "order": 3, "resolution": 8, "threads": 2})
    sol = scene.integrator().prepare(scene)
    m, lo, hi = sol.moments[0], sol.grid_min, sol.grid_max
    res = np.array(m.shape[:3])
    rng = np.random.default_rng(5)
    p = rng.uniform(lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo), size=(400, 3))
    w = rng.normal(size=(400, 3))
    w /= np.linalg.norm(w, axis=1)[:, None]
    ylm = pnsolver.real_sh(3, w)
    g = 0.7
    coeff = ylm * np.array([g ** l for l in range(4) for _ in range(2 * l + 1)])
    f = np.clip((p - lo) / (hi - lo) * res - 0.5, 0, res - 1)
    i0 = np.minimum(np.floor(f).astype(int), res - 1)
    i1 = np.minimum(i0 + 1, res - 1)
    t = f - i0
    expected = np.zeros(len(p))
    for c in range(8):
        bits = [(c >> a) & 1 for a in range(3)]
        idx = [np.where(bits[a], i1[:, a], i0[:, a]) for a in range(3)]
        wgt = np.prod([np.where(bits[a], t[:, a], 1 - t[:, a]) for a in range(3)], axis=0)
        expected += wgt * np.sum(m[idx[0], idx[1], idx[2]] * coeff, axis=1)
    inside = np.all((p >= lo) & (p <= hi), axis=1)
    expected[~inside] = 0.0
    pts = mi.Point3f(*[mi.Float(p[:, a].astype(np.float32)) for a in range(3)])
    dirs = mi.Vector3f(*[mi.Float(w[:, a].astype(np.float32)) for a in range(3)])
    got = np.asarray(sol.inscatter(pts, dirs)[0], dtype=np.float64)
    scale = np.max(np.abs(expected))
    assert inside.sum() > 100 and (~inside).sum() > 20
    assert np.max(np.abs(got - expected)) < 1e-4 * scale


def albedo_grid():
    """An albedo varying along x (0.5 … 0.98), on the density's 16³ grid, x first."""
    a = np.linspace(0.5, 0.98, 16)[:, None, None] * np.ones((16, 16, 16))
    return np.ascontiguousarray(a)


@pytest.mark.parametrize("case", ["directional, g = 0.7, P_5", "point light, RGB albedo, P_3",
                                  "albedo grid, P_3", "droplet phase, P_3"])
def test_the_integrator_equals_pnsolvers_monte_carlo_renderer(case):
    """The same estimator in two implementations: image means agree within noise. The
    droplet phase: pn's own, against the blendphase of hg and tabphase that pn export-mitsuba
    writes for it, which the integrator reads back as a resampled table."""
    use("llvm_ad_rgb")
    pn_albedo = None
    pn_phase, phase = None, None
    if case.startswith("droplet"):
        order, albedo, light, g = 3, 0.9, None, 0.0
        pn_phase = {"kind": "droplet", "diameter": 10}
        phase = pnsolver.mitsuba_phase_dict(pn_phase)
        pn_light = {"kind": "directional", "direction": [0.3, -1.0, -0.2], "irradiance": 1.0}
    elif case.startswith("directional"):
        order, albedo, light, g = 5, 0.9, None, 0.7
        pn_light = {"kind": "directional", "direction": [0.3, -1.0, -0.2], "irradiance": 1.0}
    elif case.startswith("albedo grid"):
        order, light, g = 3, None, 0.3
        pn_albedo = albedo_grid()
        albedo = {"type": "gridvolume",
                  "grid": mi.VolumeGrid(np.ascontiguousarray(
                      np.transpose(pn_albedo, (2, 1, 0))[..., None], dtype=np.float32)),
                  "to_world": mi.ScalarTransform4f().translate([-1, -1, -1]).scale(2)}
        pn_light = {"kind": "directional", "direction": [0.3, -1.0, -0.2], "irradiance": 1.0}
    else:
        order, albedo, g = 3, [0.95, 0.8, 0.6], 0.3
        light = {"type": "point", "position": [1.5, 2.0, 0.5], "intensity": 2.0}
        pn_light = {"kind": "point", "position": [1.5, 2.0, 0.5], "power": 8 * math.pi}
    scene = mitsuba_scene({"type": "pn", "order": order, "resolution": 10,
                           "tolerance": 1e-8, "threads": 2}, g=g, albedo=albedo, light=light,
                          phase=phase)
    ours = [mean_and_sigma(lambda s: mi.render(scene, spp=256, seed=s), channel=c)
            for c in range(3)]
    settings = {
        "medium": {"bbox_min": [-1.0] * 3, "bbox_max": [1.0] * 3, "sigma_t_scale": 8.0,
                   **({"albedo": albedo} if pn_albedo is None else {})},
        "phase": pn_phase or {"kind": "hg", "g": g},
        "light": [pn_light],
        "camera": {"position": [0.0, 0.0, 4.0], "target": [0.0] * 3, "up": [0.0, 1.0, 0.0],
                   "fov": 40.0, "width": 20, "height": 20},
        # The integrator's single scattering is Mitsuba's, with the true transmittance: it
        # solves without delta-M, and so does pn here.
        "solve": {"method": "pn", "order": order, "resolution": [10, 10, 10],
                  "tolerance": 1e-8, "delta_m": False},
        "render": {"renderer": "montecarlo", "spp": 256},
    }

    def pn_render(seed):
        settings["render"]["seed"] = seed
        img = pnsolver.render(pnsolver.Scene(settings, density=density(), albedo=pn_albedo),
                              threads=2)["image"]
        return img if img.ndim == 3 else np.repeat(img[..., None], 3, axis=2)

    theirs = [mean_and_sigma(pn_render, channel=c) for c in range(3)]
    for c in range(3):
        ok, detail = agree(ours[c], theirs[c])
        assert ok, (case, c, detail)
    if isinstance(albedo, list):
        assert ours[0][0] > 1.2 * ours[2][0]  # the colour came through


def test_without_a_solve_it_is_volpaths_single_scattering():
    """method = none: next-event estimation only, which is volpath with max_depth = 2."""
    use("llvm_ad_rgb")
    ours = mean_and_sigma(lambda s: mi.render(mitsuba_scene({"type": "pn", "method": "none"}),
                                              spp=256, seed=s))
    vp = mitsuba_scene({"type": "volpath", "max_depth": 2})
    theirs = mean_and_sigma(lambda s: mi.render(vp, spp=256, seed=s))
    ok, detail = agree(ours, theirs)
    assert ok, detail


def test_the_scalar_variant_renders_the_same_image():
    """scalar_rgb (Python per ray) against llvm_ad_rgb on a small image."""
    use("llvm_ad_rgb")
    props = {"type": "pn", "order": 3, "resolution": 8, "threads": 2}
    wide = mean_and_sigma(lambda s: mi.render(mitsuba_scene(props, size=8), spp=64, seed=s))
    use("scalar_rgb")
    scalar = mean_and_sigma(lambda s: mi.render(mitsuba_scene(props, size=8), spp=16, seed=s))
    ok, detail = agree(scalar, wide)
    assert ok, detail
    use("llvm_ad_rgb")


def test_one_solve_serves_many_views():
    use("llvm_ad_rgb")
    T = mi.ScalarTransform4f
    second = {"type": "perspective", "fov": 40.0,
              "to_world": T().look_at(origin=[4, 1, 0], target=[0, 0, 0], up=[0, 1, 0]),
              "film": {"type": "hdrfilm", "width": 12, "height": 12, "pixel_format": "rgb"}}
    scene = mitsuba_scene({"type": "pn", "order": 1, "resolution": 8}, size=12,
                          extra={"sensor2": second})
    integrator = scene.integrator()
    first = integrator.prepare(scene)
    a = np.asarray(mi.render(scene, spp=4, sensor=0))
    b = np.asarray(mi.render(scene, spp=4, sensor=1))
    assert integrator.solution(scene) is first
    assert a.shape == b.shape == (12, 12, 3) and a.mean() > 0 and b.mean() > 0


@pytest.mark.parametrize("change, message", [
    ({"extra": {"spot": {"type": "spot"}}}, "directional, point, envmap and constant"),
    ({"extra": {"wall": {"type": "rectangle", "bsdf": {"type": "roughconductor"}}}},
     "'diffuse' BSDF"),
    ({"sigma_t": {"type": "constvolume", "value": 1.0}}, "sigma_t must be a gridvolume"),
    ({"sigma_t": "rgb-grid"}, "one channel"),
])
def test_scenes_it_cannot_render_are_refused_with_the_reason(change, message):
    use("llvm_ad_rgb")
    if change.get("sigma_t") == "rgb-grid":
        data = np.ones((4, 4, 4, 3), dtype=np.float32)
        change = {"sigma_t": {"type": "gridvolume", "grid": mi.VolumeGrid(data),
                              "to_world": mi.ScalarTransform4f().translate([-1, -1, -1]).scale(2)}}
    scene = mitsuba_scene({"type": "pn"}, **change)
    with pytest.raises(ValueError, match=message):
        scene.integrator().prepare(scene)
    # mi.render wraps it (Dr.Jit's custom operation): the reason is in the chain.
    with pytest.raises(Exception) as info:
        mi.render(scene, spp=1)
    chain, e = [], info.value
    while e is not None:
        chain.append(str(e))
        e = e.__cause__ or e.__context__
    assert any(message in c for c in chain), chain


def test_bad_integrator_properties_are_refused():
    use("llvm_ad_rgb")
    with pytest.raises(Exception, match="method must be"):
        mitsuba_scene({"type": "pn", "method": "pm"})
    with pytest.raises(Exception, match="resolution"):
        mitsuba_scene({"type": "pn", "resolution": "8,x,8"})


def test_the_side_by_side_example_runs(tmp_path):
    if not LLVM:
        use("llvm_ad_rgb")
    png = tmp_path / "side.png"
    r = subprocess.run([sys.executable, os.path.join(ROOT, "python", "examples",
                                                     "mitsuba_side_by_side.py"),
                        "--out", str(png), "--width", "32", "--spp", "16", "--ref-spp", "64",
                        "--threads", "2", "--pn-render", "--json"],
                       capture_output=True, text=True, check=True)
    import json
    rows = json.loads(r.stdout.strip().splitlines()[-1])["rows"]
    assert set(rows) == {"volpath", "pn integrator", "pn render"}
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
