"""Bad input to the Python API and the Mitsuba integrator (issue 53): every kind is refused
with a ValueError whose message names the problem (the key, the array, the figure), before
anything large is allocated; non-contiguous arrays give the results of contiguous copies.

The Mitsuba tests need Mitsuba 3 and its llvm variant and skip or fail as
test_mitsuba_integrator.py does (PN_REQUIRE_MITSUBA, PN_REQUIRE_MITSUBA_LLVM). Mitsuba wraps
what the integrator raises: a bad property fails `mi.load_dict` with Mitsuba's RuntimeError,
whose message ends with the ValueError's; a scene it cannot render raises the ValueError from
`integrator.prepare(scene)`, and `mi.render` a RuntimeError with that ValueError as its cause.
"""

import copy
import os

import numpy as np
import pytest

import pnsolver

SETTINGS = {
    "medium": {"bbox_min": [-1.0, -1.0, -1.0], "bbox_max": [1.0, 1.0, 1.0],
               "sigma_t_scale": 8.0, "albedo": 0.9},
    "phase": {"kind": "hg", "g": 0.3},
    "light": [{"kind": "directional", "direction": [0.3, -1.0, -0.2], "irradiance": 1.0}],
    "camera": {"position": [0.0, 0.0, 4.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0],
               "fov": 40.0, "width": 8, "height": 8},
    "solve": {"method": "pn", "order": 1, "resolution": [6, 6, 6], "tolerance": 1e-8},
}


def density():
    """An asymmetric 8 × 9 × 10 medium (a transposed or reversed axis would show)."""
    d = np.zeros((8, 9, 10))
    d[1:7, 2:8, 1:9] = 1.0
    d[3, 4, 5] = 3.0
    return d


def albedo():
    return np.linspace(0.2, 0.95, density().size).reshape(density().shape)


def sky():
    return np.random.default_rng(1).uniform(0.1, 1.0, (8, 16, 3))


def at(a, index, value):
    """`a` with `value` at `index`."""
    a = a.copy()
    a[index] = value
    return a


def settings(change=None):
    s = copy.deepcopy(SETTINGS)
    if change:
        change(s)
    return s


def with_sky(s):
    s["light"] = [{"kind": "envmap"}]


def refused(message, make):
    """`make()` raises a ValueError whose message contains `message`; the interpreter goes on."""
    with pytest.raises(ValueError) as e:
        make()
    assert message in str(e.value)
    return str(e.value)


# --------------------------------------------------------------------------------------
# Arrays


@pytest.mark.parametrize("dtype", [np.int32, np.int64, np.uint8, bool, np.complex128, object,
                                   str, np.float16, np.longdouble, ">f8"])
def test_arrays_of_a_wrong_dtype_are_refused_naming_the_array_and_dtype(dtype):
    d, a = density().astype(dtype), albedo().astype(dtype)
    refused(f"density must be a numpy array of float64 or float32, got {d.dtype}",
            lambda: pnsolver.Scene(SETTINGS, density=d))
    refused(f"albedo must be a numpy array of float64 or float32, got {a.dtype}",
            lambda: pnsolver.Scene(SETTINGS, density=density(), albedo=a))
    refused("envmap must be a numpy array of float64 or float32",
            lambda: pnsolver.Scene(settings(with_sky), density=density(),
                                   envmap=sky().astype(dtype)))


@pytest.mark.parametrize("call, message", [
    (lambda: pnsolver.Scene(SETTINGS, density=[[[1.0]]]), "float64 or float32, got <class 'list'>"),
    (lambda: pnsolver.real_sh(2, np.ones((1, 3), dtype=complex)),
     "directions must hold real numbers (float or int), got dtype complex128"),
    (lambda: pnsolver.real_sh(2, [["x", "y", "z"]]), "directions must hold real numbers"),
    (lambda: pnsolver.phase_value({"kind": "hg", "g": 0.5}, np.ones(3, dtype=complex)),
     "mu must hold real numbers (float or int), got dtype complex128"),
    (lambda: pnsolver.phase_value({"kind": "hg", "g": 0.5}, "forward"),
     "mu must hold real numbers"),
    (lambda: pnsolver.real_sh(64, np.broadcast_to(np.array([0.0, 0.0, 1.0]), (1 << 40, 3))),
     "the result would hold 4645436627353600 values, about 33.01 PiB, more than the memory "
     "limit of"),
])
def test_other_wrong_types_of_arrays_are_refused(call, message):
    refused(message, call)


def test_real_sh_takes_float32_int_and_lists_as_float64():
    ref = pnsolver.real_sh(3, np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]))
    for d in (np.array([[0, 0, 1], [1, 0, 0]]), np.array([[0, 0, 1], [1, 0, 0]], np.float32),
              [[0, 0, 1.0], [1, 0, 0]]):
        assert np.array_equal(pnsolver.real_sh(3, d), ref)


@pytest.mark.parametrize("make, message", [
    (lambda: pnsolver.Scene(SETTINGS, density=np.where(density() > 2, np.nan, density())),
     "density: density must be finite and non-negative, voxel (3, 4, 5) is NaN"),
    (lambda: pnsolver.Scene(SETTINGS, density=np.where(density() > 2, np.inf, density())),
     "voxel (3, 4, 5) is inf"),
    (lambda: pnsolver.Scene(SETTINGS, density=np.where(density() > 2, -1.0, density())),
     "voxel (3, 4, 5) is -1"),
    (lambda: pnsolver.Scene(SETTINGS, density=density(),
                            albedo=np.where(density() > 2, np.nan, albedo())),
     "albedo: albedo must lie in [0, 1], voxel (3, 4, 5) is NaN"),
    (lambda: pnsolver.Scene(SETTINGS, density=density(),
                            albedo=np.where(density() > 2, -0.5, albedo())),
     "albedo must lie in [0, 1], voxel (3, 4, 5) is -0.5"),
    (lambda: pnsolver.Scene(SETTINGS, density=density(),
                            albedo=np.where(density() > 2, 1.5, albedo())),
     "albedo must lie in [0, 1], voxel (3, 4, 5) is 1.5"),
    (lambda: pnsolver.Scene(settings(with_sky), density=density(),
                            envmap=at(np.ones((8, 16, 3)), (2, 3, 1), np.nan)),
     "envmap: texel (row 2, column 3) is [1.0, NaN, 1.0]: radiance must be finite and "
     "non-negative"),
    (lambda: pnsolver.Scene(settings(with_sky), density=density(),
                            envmap=at(np.ones((8, 16, 3)), (2, 3, 1), -1.0)),
     "texel (row 2, column 3) is [1.0, -1.0, 1.0]"),
])
def test_nan_infinite_and_negative_values_are_refused_naming_the_voxel(make, message):
    refused(message, make)


@pytest.mark.parametrize("make, message", [
    (lambda: pnsolver.Scene(SETTINGS, density=np.zeros((0, 4, 4))),
     "density has a zero-length axis: shape [0, 4, 4]"),
    (lambda: pnsolver.Scene(SETTINGS, density=np.zeros((4, 4, 0), np.float32)),
     "density has a zero-length axis: shape [4, 4, 0]"),
    (lambda: pnsolver.Scene(SETTINGS, density=np.zeros((0, 4, 4)), albedo=np.zeros((0, 4, 4))),
     "density has a zero-length axis"),
    (lambda: pnsolver.Scene(settings(with_sky), density=density(), envmap=np.zeros((0, 0, 3))),
     "envmap: an environment map needs at least 3 rows (6 × 3 texels), got 0 × 0"),
    (lambda: pnsolver.Scene(settings(lambda s: s["medium"].update(
        kind="box", resolution=[0, 8, 8])), density=None),
     "medium.resolution must be positive on every axis, got [0, 8, 8]"),
])
def test_zero_sized_arrays_are_refused(make, message):
    refused(message, make)


@pytest.mark.parametrize("make, message", [
    (lambda: pnsolver.Scene(SETTINGS, density=np.ones((4, 4))),
     "density must have shape (nx, ny, nz) (x first), got shape [4, 4]"),
    (lambda: pnsolver.Scene(SETTINGS, density=np.ones((2, 4, 4, 4))), "got shape [2, 4, 4, 4]"),
    (lambda: pnsolver.Scene(SETTINGS, density=np.float64(1.0)), "density must be a numpy array"),
    (lambda: pnsolver.Scene(SETTINGS, density=density(), albedo=np.ones((8, 9))),
     "albedo must have shape (nx, ny, nz)"),
    (lambda: pnsolver.Scene(SETTINGS, density=density(), albedo=np.ones((8, 10, 9))),
     "albedo has shape [8, 10, 9], the density [8, 9, 10]"),
    (lambda: pnsolver.Scene(settings(with_sky), density=density(), envmap=np.ones((8, 16, 4))),
     "must have shape (height, width, 3) or (height, width), got [8, 16, 4]"),
    (lambda: pnsolver.real_sh(2, np.ones(3)), "directions must have shape (n, 3), got [3]"),
])
def test_arrays_of_a_wrong_rank_or_shape_are_refused(make, message):
    refused(message, make)


def solved(**arrays):
    """The moments of the test scene with `arrays` (density, albedo, envmap) on one thread
    (bit-for-bit reproducible)."""
    s = settings(with_sky) if "envmap" in arrays else settings()
    scene = pnsolver.Scene(s, **{"density": density(), **arrays})
    return pnsolver.solve(scene.channel(0), threads=1)["moments"]


@pytest.mark.parametrize("name, view", [
    ("every other x", lambda a: np.repeat(a, 2, axis=0)[::2]),
    ("every third z", lambda a: np.repeat(a, 3, axis=2)[:, :, ::3]),
    ("Fortran order", np.asfortranarray),
    ("transposed", lambda a: np.ascontiguousarray(a.transpose(2, 0, 1)).transpose(1, 2, 0)),
    ("reversed", lambda a: np.ascontiguousarray(a[::-1, :, ::-1])[::-1, :, ::-1]),
    ("float32 slice of a wider array",
     lambda a: np.concatenate([a, a], axis=1).astype(np.float32)[:, : a.shape[1]]),
])
def test_non_contiguous_arrays_give_the_results_of_a_contiguous_copy(name, view):
    d, a, m = density(), albedo(), sky()
    if "float32" in name:  # the reference: the same float32 values, contiguous
        d, a, m = (x.astype(np.float32) for x in (d, a, m))
    views = {"density": view(density()), "albedo": view(albedo()), "envmap": view(sky())}
    assert not views["density"].flags["C_CONTIGUOUS"]
    assert np.array_equal(solved(density=views["density"]), solved(density=d))
    assert np.array_equal(solved(albedo=views["albedo"]), solved(albedo=a))
    assert np.array_equal(solved(envmap=views["envmap"]), solved(envmap=m))


@pytest.mark.parametrize("make, message", [
    # Broadcast views: no memory behind them, the shape alone is refused (a copy would abort
    # the interpreter: 8 PB cannot be allocated).
    (lambda: pnsolver.Scene(SETTINGS, density=np.broadcast_to(1.0, (100000, 100000, 100000))),
     "density of shape [100000, 100000, 100000] is 1000000000000000 voxels: copying it takes "
     "about 10.66 PiB, more than the memory limit of"),
    (lambda: pnsolver.Scene(SETTINGS, density=np.broadcast_to(np.float32(1.0), (1 << 17,) * 3),
                            albedo=np.broadcast_to(np.float32(0.5), (1 << 17,) * 3)),
     "copying it and the albedo takes about 48.00 PiB"),
    (lambda: pnsolver.Scene(settings(lambda s: s["medium"].update(
        kind="box", resolution=[100000, 100000, 100000]))),
     "medium.resolution [100000, 100000, 100000] is 1000000000000000 voxels, about 3.55 PiB "
     "as float32; a procedural medium has at most 512³ = 134217728 voxels"),
    (lambda: pnsolver.Scene(settings(with_sky), density=density(),
                            envmap=np.broadcast_to(np.float32(1.0), (8192, 16384, 3))),
     "envmap: an environment map of 16384 × 8192 texels would take 1.6 GB; the largest "
     "accepted is 4096 × 2048"),
    (lambda: pnsolver.Scene(settings(lambda s: s["solve"].update(resolution=[100000] * 3)),
                            density=density()),
     "solve resolution must be between 1 and 4096 per axis"),
    (lambda: pnsolver.Scene(settings(lambda s: s["camera"].update(width=100000)),
                            density=density()),
     "image size must be between 1 and 16384 pixels per side"),
])
def test_absurd_sizes_are_refused_with_the_figure_before_anything_is_allocated(make, message):
    refused(message, make)


# --------------------------------------------------------------------------------------
# Scene dictionaries and arguments


def light2(**kw):
    return lambda s: s["light"].append({"kind": "point", "position": [0, 2, 0], "power": 1.0,
                                        **kw})


@pytest.mark.parametrize("make, message", [
    (lambda: pnsolver.Scene([("medium", {})]), "settings must be a dictionary"),
    (lambda: pnsolver.Scene(None), "settings must be a dictionary"),
    (lambda: pnsolver.Scene("cloud"), "Scene.load reads a built-in scene"),
    (lambda: pnsolver.Scene({}), "settings: missing field `medium`"),
    (lambda: pnsolver.Scene(settings(lambda s: s.pop("medium")), density=density()),
     'settings need a "medium" section'),
    (lambda: pnsolver.Scene(settings(lambda s: s.update(zoom=2)), density=density()),
     "settings.zoom: unknown field `zoom`"),
    (lambda: pnsolver.Scene(settings(lambda s: s["medium"].update(colour=1)), density=density()),
     "settings.medium.colour: unknown field `colour`"),
    (lambda: pnsolver.Scene(settings(lambda s: s["medium"].pop("sigma_t_scale")),
                            density=density()),
     "settings.medium: missing field `sigma_t_scale`"),
    (lambda: pnsolver.Scene(settings(lambda s: s["solve"].update(order="3")), density=density()),
     'settings.solve.order: invalid type: string "3", expected a non-negative integer'),
    (lambda: pnsolver.Scene(settings(lambda s: s["solve"].update(order=-1)), density=density()),
     "settings.solve.order: invalid value: integer `-1`, expected a non-negative integer"),
    (lambda: pnsolver.Scene(settings(lambda s: s["solve"].update(order=10**30)), density=density()),
     "settings.solve.order: the integer 1000000000000000000000000000000 is too large"),
    (lambda: pnsolver.Scene(settings(lambda s: s["solve"].update(order={3})), density=density()),
     "settings.solve.order: expected a number, string, list, dictionary or numpy array"),
    (lambda: pnsolver.Scene(settings(lambda s: s["solve"].update(order=None)), density=density()),
     "settings.solve.order: None is not a value"),
    (lambda: pnsolver.Scene(settings(lambda s: s.update(light={"kind": "point"})),
                            density=density()),
     "settings.light: invalid type: dictionary, expected a list"),
    (lambda: pnsolver.Scene(settings(light2(power="bright")), density=density()),
     "settings.light[1].power"),
    (lambda: pnsolver.Scene(settings(light2(power=-1.0)), density=density()),
     'light 2 (kind = "point"): power must be finite and non-negative, got -1'),
    (lambda: pnsolver.Scene(settings(lambda s: s["medium"].update(sigma_t_scale=float("nan"))),
                            density=density()),
     "medium.sigma_t_scale must be finite and non-negative, got NaN"),
    (lambda: pnsolver.Scene(settings(lambda s: s["medium"].update(albedo=-0.1)),
                            density=density()),
     "medium.albedo must lie in [0, 1], got -0.1"),
    (lambda: pnsolver.Scene(settings(lambda s: s["camera"].update(fov=float("nan"))),
                            density=density()),
     "camera fov must lie in (0, 180) degrees, got NaN"),
    (lambda: pnsolver.Scene(settings(lambda s: s["solve"].update(tolerance=-1.0)),
                            density=density()),
     "tolerance must lie in (0, 1), got -1"),
    (lambda: pnsolver.Scene(settings(lambda s: s["medium"].update(resolution=[100000] * 3)),
                            density=density()),
     "medium.resolution [100000, 100000, 100000] disagrees with the density array's shape "
     "[8, 9, 10]; leave it out"),
    (lambda: pnsolver.Scene(settings(lambda s: s.update(phase="hg")), density=density()),
     'settings.phase: invalid type: string "hg", expected a dictionary'),
    (lambda: pnsolver.Scene(settings(lambda s: s["phase"].update(gg=0.3)), density=density()),
     "settings.phase.gg: unknown field `gg`"),
    (lambda: pnsolver.Scene(settings(lambda s: s.update(phase={"kind": "hg", "g": float("nan")})),
                            density=density()),
     "Henyey–Greenstein g must satisfy |g| < 1, got NaN"),
    (lambda: pnsolver.Scene(settings(lambda s: s.update(phase={"kind": "tabulated",
                                                                "values": np.ones((2, 2))})),
                            density=density()),
     "settings.phase.values: invalid type: list, expected a number"),
    (lambda: pnsolver.Scene(settings(lambda s: s.update(phase={"kind": "isotropic", "g": 0.5})),
                            density=density()),
     'g does not apply to kind = "isotropic"'),
])
def test_bad_scene_dictionaries_are_refused_naming_the_key(make, message):
    refused(message, make)
    # Still usable afterwards.
    assert pnsolver.Scene(SETTINGS, density=density()).name == "python"


@pytest.mark.parametrize("call, message", [
    (lambda s: pnsolver.render(s, threads=-1), "threads must lie in 1..="),
    (lambda s: pnsolver.solve(s, threads=0), "threads must lie in 1..="),
    (lambda s: pnsolver.solve(s, threads=10**6), "threads must lie in 1..="),
    (lambda s: pnsolver.solve(s, callback=3), "callback must be callable"),
    (lambda s: s.channel(-1), "channel must be 0, 1 or 2 (R, G, B), got -1"),
    (lambda s: pnsolver.real_sh(-1, np.eye(3)), "lmax must lie in 0..=64, got -1"),
    (lambda s: pnsolver.phase_moments({"kind": "hg", "g": 0.5}, -1),
     "lmax must lie in 0..=4096, got -1"),
    (lambda s: pnsolver.phase_moments([0.5], 3), "the phase must be a dictionary"),
])
def test_bad_arguments_are_value_errors_not_overflow_or_type_errors(call, message):
    refused(message, lambda: call(pnsolver.Scene(SETTINGS, density=density())))


# --------------------------------------------------------------------------------------
# The Mitsuba integrator


@pytest.fixture
def tmi():
    """test_mitsuba_integrator.py with Mitsuba's llvm variant selected and the integrator
    registered: skipped without Mitsuba or its llvm variant, or failed, as there."""
    if not os.environ.get("PN_REQUIRE_MITSUBA"):
        pytest.importorskip("mitsuba")
    import test_mitsuba_integrator as t
    t.use("llvm_ad_rgb")
    return t


@pytest.mark.parametrize("props, message", [
    ({"method": "pm"}, "method must be pn, cda, fld or none, got 'pm'"),
    ({"order": -1}, "order: invalid value: integer `-1`, expected a non-negative integer"),
    ({"order": 0}, "order must lie in 1..="),
    ({"order": 2.5}, "order must be an integer, got 2.5"),
    ({"order": "three"}, "order must be an integer, got 'three'"),
    ({"resolution": 0}, "solve resolution must be between 1 and 4096 per axis, got [0, 0, 0]"),
    ({"resolution": 100000}, "solve resolution must be between 1 and 4096 per axis"),
    ({"resolution": "8,8"}, "resolution must be an integer or 'nx,ny,nz', got '8,8'"),
    ({"resolution": "8,x,8"}, "resolution must be an integer or 'nx,ny,nz'"),
    ({"resolution": 6.5}, "resolution must be an integer or 'nx,ny,nz', got 6.5"),
    ({"tolerance": float("nan")}, "tolerance must lie in (0, 1), got NaN"),
    ({"tolerance": "tight"}, "tolerance must be a number, got 'tight'"),
    ({"threads": -1}, "threads must be at least 1, got -1"),
    ({"margin": -1}, "margin: invalid value: integer `-1`"),
    ({"sweeps": 1000}, "sweeps must be at most 100, got 1000"),
    ({"absorber_width": 5.0}, "absorber_width must lie in [0, 1]"),
    ({"surface_light": "maybe"}, "surface_light must be true or false, got 'maybe'"),
    # Mitsuba's own checks: a property nobody reads, the base class's hide_emitters.
    ({"ordr": 3}, 'unreferenced property in unknown plugin of type "pn"'),
    ({"hide_emitters": "false"}, 'The property "hide_emitters" has the wrong type'),
])
def test_bad_integrator_properties_fail_when_the_scene_loads(tmi, props, message):
    with pytest.raises(RuntimeError) as e:
        tmi.mitsuba_scene({"type": "pn", **props}, size=8)
    text = str(e.value)
    assert message in text, text
    if "unreferenced" not in message and "wrong type" not in message:
        assert f"ValueError: pn integrator: {message}" in text, text


def nan_grid(mi, value, shape=(16, 16, 16)):
    d = np.ones(shape)
    d[9, 7, 5] = value  # (z, y, x): voxel (x, y, z) = (5, 7, 9)
    return {"type": "gridvolume", "grid": mi.VolumeGrid(d[..., None].astype(np.float32)),
            "to_world": mi.ScalarTransform4f().translate([-1, -1, -1]).scale(2)}


@pytest.mark.parametrize("change, message", [
    (lambda mi: {"sigma_t": nan_grid(mi, np.nan)},
     "the medium's sigma_t grid must be finite and non-negative: voxel (x, y, z) = (5, 7, 9) "
     "is nan"),
    (lambda mi: {"sigma_t": nan_grid(mi, -1.0)}, "voxel (x, y, z) = (5, 7, 9) is -1.0"),
    (lambda mi: {"sigma_t": nan_grid(mi, np.inf)}, "voxel (x, y, z) = (5, 7, 9) is inf"),
    (lambda mi: {"albedo": nan_grid(mi, np.nan)},
     "albedo: albedo must lie in [0, 1], voxel (5, 7, 9) is NaN"),
    (lambda mi: {"albedo": nan_grid(mi, 2.0)}, "albedo must lie in [0, 1], voxel (5, 7, 9) is 2"),
    (lambda mi: {"albedo": float("nan")}, "medium.albedo must lie in [0, 1], got NaN"),
    (lambda mi: {"light": {"type": "directional", "direction": [0, -1, 0],
                           "irradiance": float("nan")}},
     'light 1 (kind = "directional"): irradiance must be finite and non-negative, got NaN'),
    (lambda mi: {"light": {"type": "spot"}},
     "supports directional, point, envmap and constant emitters, not SpotLight"),
    (lambda mi: {"extra": {"lamp": {"type": "rectangle",
                                    "emitter": {"type": "area", "radiance": 1.0},
                                    "to_world": mi.ScalarTransform4f().translate([0, 3, 0])}}},
     "area emitters (Rectangle) are not supported by the pn integrator"),
])
def test_media_and_emitters_it_cannot_take_are_refused_with_the_reason(tmi, change, message):
    scene = tmi.mitsuba_scene({"type": "pn", "order": 1, "resolution": 6}, size=8,
                              **change(tmi.mi))
    with pytest.raises(ValueError) as e:
        scene.integrator().prepare(scene)
    assert message in str(e.value)
    # mi.render wraps it (Dr.Jit's custom operation): a RuntimeError caused by the ValueError.
    with pytest.raises(RuntimeError) as info:
        tmi.mi.render(scene, spp=1)
    chain, err = [], info.value
    while err is not None:
        chain.append(f"{type(err).__name__}: {err}")
        err = err.__cause__ or err.__context__
    assert any(c.startswith("ValueError") and message in c for c in chain), chain
