"""Sky lights from Python (issue 50): `pnsolver.Scene(settings, envmap=array)` replaces the
file of the scene's `kind = "envmap"` light with a numpy map (row 0 = +Y, Mitsuba's
orientation); bad maps raise ValueError naming the problem."""

import numpy as np
import pytest

import pnsolver


def settings(lights, hide=False):
    return {
        "medium": {"bbox_min": [-1.0, -1.0, -1.0], "bbox_max": [1.0, 1.0, 1.0],
                   "sigma_t_scale": 6.0, "albedo": 0.9},
        "phase": {"kind": "hg", "g": 0.3},
        "light": lights,
        "camera": {"position": [0.0, 0.0, 4.0], "target": [0.0, 0.0, 0.0],
                   "up": [0.0, 1.0, 0.0], "fov": 40.0, "width": 16, "height": 16},
        "solve": {"method": "pn", "order": 1, "resolution": [8, 8, 8]},
        "render": {"hide_emitters": hide},
    }


def density():
    d = np.zeros((12, 12, 12))
    d[2:10, 2:10, 2:10] = 1.0
    return d


def test_a_uniform_map_is_the_constant_sky():
    """An RGB map of one value renders as the constant sky of that value (the same median
    cut: equal but for the float32 map, within 1e-3), and makes the scene coloured."""
    rgb = [0.4, 0.2, 0.1]
    const = pnsolver.Scene(settings([{"kind": "constant", "radiance": rgb}]), density=density())
    env = np.broadcast_to(np.array(rgb, dtype=np.float32), (16, 32, 3)).copy()
    mapped = pnsolver.Scene(settings([{"kind": "envmap"}]), density=density(), envmap=env)
    assert mapped.coloured
    a = pnsolver.render(const, threads=2)["image"]
    b = pnsolver.render(mapped, threads=2)["image"]
    assert a.shape == b.shape == (16, 16, 3)
    assert np.allclose(a, b, rtol=1e-3, atol=1e-6)


def test_a_grey_map_keeps_a_grey_scene_grey_and_an_rgb_map_keeps_the_sun():
    sun = {"kind": "directional", "direction": [0.0, -1.0, 0.0], "irradiance": 2.0}
    grey = pnsolver.Scene(settings([sun, {"kind": "envmap", "scale": 0.5}]), density=density(),
                          envmap=np.ones((8, 16)))
    assert not grey.coloured
    img = pnsolver.render(grey, threads=2)["image"]
    assert img.ndim == 2
    # An RGB map with equal channels except blue: the sun stays in every channel.
    env = np.ones((8, 16, 3))
    env[..., 2] = 2.0
    rgb = pnsolver.Scene(settings([sun, {"kind": "envmap", "scale": 0.5}]), density=density(),
                         envmap=env)
    assert rgb.coloured
    col = pnsolver.render(rgb, threads=2)["image"]
    assert np.allclose(col[..., 0], img, rtol=1e-3, atol=1e-6)
    assert np.allclose(col[..., 1], img, rtol=1e-3, atol=1e-6)
    assert col[..., 2].mean() > 1.2 * img.mean()


def _patch(column):
    """A 32 × 64 map, dim everywhere, bright around the horizon texel of `column`."""
    env = np.full((32, 64), 0.01)
    env[13:19, column - 3:column + 4] = 50.0
    return env


def _sides(env):
    scene = pnsolver.Scene(settings([{"kind": "envmap"}], hide=True), density=density(),
                           envmap=env)
    img = pnsolver.render(scene, threads=2)["image"]
    return img[:, :8].mean(), img[:, 8:].mean()


def test_the_map_lights_the_medium_from_its_side():
    """Row 0 is +Y and u = atan2(x, -z)/2π: a bright patch at u = 1/4 is at +x, which the
    camera on +z looking at the origin (up +y) sees on the right; at u = 3/4, on the left."""
    left, right = _sides(_patch(16))
    assert right > 1.5 * left, (left, right)
    left, right = _sides(_patch(48))
    assert left > 1.5 * right, (left, right)
    # A patch overhead (row 0 is +Y) lights the top of the image.
    env = np.full((32, 64), 0.01)
    env[:3] = 50.0
    scene = pnsolver.Scene(settings([{"kind": "envmap"}], hide=True), density=density(),
                           envmap=env)
    img = pnsolver.render(scene, threads=2)["image"]
    assert img[:8].mean() > 1.5 * img[8:].mean()


@pytest.mark.parametrize("env, message", [
    (np.ones((16, 16)), "twice as wide as high"),
    (np.ones((16, 32, 4)), "shape (height, width, 3) or (height, width)"),
    (np.ones((2, 4, 3)), "at least 3 rows"),
    (np.ones((16, 32), dtype=np.int64), "float64 or float32"),
    (np.full((16, 32), np.nan), "finite and non-negative"),
    (np.full((16, 32), np.inf), "finite and non-negative"),
    (-np.ones((16, 32)), "finite and non-negative"),
    (np.zeros((16, 32)), "the sky is black"),
    ([[1.0, 1.0]], "must be a numpy array"),
])
def test_bad_maps_are_refused(env, message):
    with pytest.raises(ValueError, match="envmap") as e:
        pnsolver.Scene(settings([{"kind": "envmap"}]), density=density(), envmap=env)
    assert message in str(e.value)


def test_a_huge_map_is_refused_before_it_is_read():
    # A broadcast view: no memory behind it, the shape alone is refused.
    huge = np.broadcast_to(np.float32(1.0), (8192, 16384))
    with pytest.raises(ValueError, match="the largest accepted is 4096 × 2048"):
        pnsolver.Scene(settings([{"kind": "envmap"}]), density=density(), envmap=huge)


@pytest.mark.parametrize("lights, message", [
    ([{"kind": "envmap", "file": "sky.exr"}], "leave file out"),
    ([{"kind": "envmap", "radiance": 1.0}], "leave radiance out"),
    ([{"kind": "constant", "radiance": 1.0}], "needs a light of kind = \"envmap\""),
    ([{"kind": "envmap", "scale": -1.0}], "scale must be"),
    ([{"kind": "envmap", "to_world": [[1, 0, 0], [0, 2, 0], [0, 0, 1]]}],
     'light 1 (kind = "envmap"): to_world must be a rotation'),
])
def test_the_settings_must_fit_the_map(lights, message):
    with pytest.raises(ValueError) as e:
        pnsolver.Scene(settings(lights), density=density(), envmap=np.ones((8, 16)))
    assert message in str(e.value)


def test_an_envmap_light_without_map_or_file_is_refused():
    with pytest.raises(ValueError, match="needs file"):
        pnsolver.Scene(settings([{"kind": "envmap"}]), density=density())
