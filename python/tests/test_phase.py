"""Phase functions from Python: the dictionaries of the scene format's `[phase]` table,
`phase_moments`, `phase_value` and `mitsuba_phase_dict` (no Mitsuba needed here; the
comparison with Mitsuba's own evaluation is in test_mitsuba_phase.py)."""

import json
import math

import numpy as np
import pytest

import pnsolver

from test_pnsolver import SETTINGS, density

PHASES = {
    "isotropic": {"kind": "isotropic"},
    "hg": {"kind": "hg", "g": 0.8},
    "two_term_hg": {"kind": "two_term_hg", "g1": 0.9, "g2": -0.3, "weight": 0.2},
    "tabulated": {"kind": "tabulated", "values": np.array([0.0, 0.5, 1.0])},
    "tabulated, irregular": {"kind": "tabulated", "cos_theta": np.array([-1.0, 0.5, 1.0]),
                             "values": [0.0, 1.5, 2.0]},
    "droplet": {"kind": "droplet", "diameter": 10},
}


def integral(phase, f=lambda mu: 1.0):
    """2π ∫ p(μ) f(μ) dμ by Gauss–Legendre on pieces graded towards the forward peak."""
    x, w = np.polynomial.legendre.leggauss(64)
    breaks = [-1.0, 0.0, 0.5] + [1.0 - 0.5 ** k for k in range(2, 24)] + [1.0]
    s = 0.0
    for a, b in zip(breaks[:-1], breaks[1:]):
        mu = a + 0.5 * (x + 1.0) * (b - a)
        s += 2.0 * math.pi * 0.5 * (b - a) * np.sum(w * pnsolver.phase_value(phase, mu) * f(mu))
    return s


@pytest.mark.parametrize("name", PHASES)
def test_values_are_normalised_and_the_moments_are_their_legendre_factors(name):
    phase = PHASES[name]
    m = pnsolver.phase_moments(phase, 6)
    assert m.shape == (7,) and m.dtype == np.float64
    assert abs(m[0] - 1.0) < 1e-12
    assert abs(integral(phase) - 1.0) < 1e-9
    for l in (1, 2, 5):
        pl = np.polynomial.legendre.Legendre.basis(l)
        assert abs(integral(phase, pl) - m[l]) < 1e-8, (l, integral(phase, pl), m[l])


def test_the_moments_of_each_kind():
    l = np.arange(8)
    np.testing.assert_array_equal(pnsolver.phase_moments(PHASES["isotropic"], 7), l == 0)
    np.testing.assert_allclose(pnsolver.phase_moments(PHASES["hg"], 7), 0.8 ** l, rtol=1e-14)
    # weight: the second lobe's share (Mitsuba's blendphase).
    np.testing.assert_allclose(pnsolver.phase_moments(PHASES["two_term_hg"], 7),
                               0.8 * 0.9 ** l + 0.2 * (-0.3) ** l, rtol=1e-14, atol=1e-16)
    # p ∝ 1 + μ on both grids: g = 1/3, nothing above l = 1.
    for name in ("tabulated", "tabulated, irregular"):
        m = pnsolver.phase_moments(PHASES[name], 4)
        np.testing.assert_allclose(m, [1.0, 1.0 / 3.0, 0.0, 0.0, 0.0], atol=1e-14)
    g = pnsolver.phase_moments(PHASES["droplet"], 1)[1]
    assert 0.8 < g < 0.9, g
    # numpy scalars and an int diameter are numbers too.
    assert pnsolver.phase_moments({"kind": "droplet", "diameter": np.float32(10.0)}, 1)[1] == g
    assert pnsolver.phase_moments({"kind": "hg", "g": np.float64(0.8)}, 2)[2] == 0.8 ** 2


def test_values_keep_the_shape_and_forward_is_mu_one():
    mu = np.linspace(-1, 1, 12).reshape(3, 4)
    v = pnsolver.phase_value(PHASES["hg"], mu)
    assert v.shape == (3, 4) and v.dtype == np.float64
    g = 0.8
    np.testing.assert_allclose(
        v, (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * mu) ** 1.5), rtol=1e-14)
    assert pnsolver.phase_value(PHASES["hg"], 1.0) > 100 * pnsolver.phase_value(PHASES["hg"], -1.0)
    assert float(pnsolver.phase_value(PHASES["isotropic"], 0.3)) == pytest.approx(1 / (4 * np.pi))
    # The table's last value is forward: p(1) = 1/(2π) for p ∝ 1 + μ, p(−1) = 0.
    t = pnsolver.phase_value(PHASES["tabulated"], [-1.0, 0.0, 1.0])
    np.testing.assert_allclose(t, [0.0, 0.25 / np.pi, 0.5 / np.pi], atol=1e-15)
    with pytest.raises(ValueError, match=r"cosines in \[-1, 1\]"):
        pnsolver.phase_value(PHASES["hg"], [0.0, 1.5])
    with pytest.raises(ValueError, match=r"cosines in \[-1, 1\]"):
        pnsolver.phase_value(PHASES["hg"], np.nan)


@pytest.mark.parametrize("phase, message", [
    ({"kind": "hg", "g": 1.0}, r"\|g\| < 1"),
    ({"kind": "hg", "g": -1.2}, r"\|g\| < 1"),
    ({"kind": "hg"}, "needs g"),
    ({"kind": "two_term_hg", "g1": 0.5, "g2": 0.1, "weight": 1.5}, r"weight must lie in \[0, 1\]"),
    ({"kind": "two_term_hg", "g1": 0.5, "g2": 1.1, "weight": 0.5}, "g2"),
    ({"kind": "tabulated", "values": np.array([1.0, -0.5, 1.0])}, r"values\[1\]"),
    ({"kind": "tabulated", "values": np.array([1.0, np.nan])}, r"values\[1\] = NaN"),
    ({"kind": "tabulated", "values": [1.0]}, "at least two values"),
    ({"kind": "tabulated", "values": [1.0, 1.0, 1.0], "cos_theta": [-1.0, 0.5, 0.2]},
     r"cos_theta\[2\].*sorted|sorted.*cos_theta\[2\]"),
    ({"kind": "droplet", "diameter": 4.0}, r"diameter must lie in \[5, 50\]"),
    ({"kind": "droplet", "diameter": 60}, "diameter"),
    ({"kind": "droplet", "diameter": 10, "g": 0.5}, "g does not apply"),
    ({"kind": "hg", "g": 0.5, "values": [1.0, 1.0]}, "values does not apply"),
    ({"kind": "mie"}, "unknown kind"),
    ({"kind": "hg", "g": None}, r"phase\.g: None"),
    ({"kind": "hg", "g": "0.5"}, "invalid type"),
    ({"kind": "hg", "gg": 0.5}, "unknown field `gg`"),
    ("hg", "dictionary"),
])
def test_bad_phases_raise_value_error_naming_the_key(phase, message):
    for call in (lambda: pnsolver.phase_moments(phase, 3),
                 lambda: pnsolver.phase_value(phase, [0.0]),
                 lambda: pnsolver.mitsuba_phase_dict(phase)):
        with pytest.raises(ValueError, match=message):
            call()


def test_the_mitsuba_dicts():
    assert pnsolver.mitsuba_phase_dict(PHASES["hg"]) == {"type": "hg", "g": 0.8}
    assert pnsolver.mitsuba_phase_dict(PHASES["two_term_hg"]) == {
        "type": "blendphase", "weight": 0.2,
        "phase1": {"type": "hg", "g": 0.9}, "phase2": {"type": "hg", "g": -0.3}}
    tab = pnsolver.mitsuba_phase_dict(PHASES["tabulated, irregular"])
    assert tab["type"] == "tabphase" and len(tab["values"].split(", ")) == 4097
    d = pnsolver.mitsuba_phase_dict(PHASES["droplet"])
    assert (d["type"], d["phase1"]["type"], d["phase2"]["type"]) == ("blendphase", "hg", "tabphase")


def scene_with(phase):
    settings = json.loads(json.dumps(SETTINGS))
    settings["phase"] = phase
    settings["solve"]["order"] = 1
    return pnsolver.Scene(settings, density=density())


def test_scene_dicts_take_every_kind_and_numpy_arrays():
    for name, phase in PHASES.items():
        assert scene_with(phase).name == "python", name
    # The phase reaches the solve: two equal lobes are one, a table of p ∝ 1 + μ differs.
    one = pnsolver.solve(scene_with({"kind": "hg", "g": 0.3}), threads=1)["moments"]
    two = pnsolver.solve(scene_with({"kind": "two_term_hg", "g1": 0.3, "g2": 0.3,
                                     "weight": np.float64(0.4)}), threads=1)["moments"]
    np.testing.assert_allclose(two, one, rtol=1e-12, atol=1e-14 * np.abs(one).max())
    tab = pnsolver.solve(scene_with(PHASES["tabulated"]), threads=1)["moments"]
    assert np.abs(tab - one).max() > 1e-3 * np.abs(one).max()
    with pytest.raises(ValueError, match=r"\[phase\].*weight"):
        scene_with({"kind": "two_term_hg", "g1": 0.3, "g2": 0.3, "weight": 2.0})
    with pytest.raises(ValueError, match=r"settings\.phase\.g: None"):
        scene_with({"kind": "hg", "g": None})
