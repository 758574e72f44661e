"""The phase functions against Mitsuba 3: the dicts `pn export-mitsuba` writes
(`pnsolver.mitsuba_phase_dict`, the same Rust function `pn_render::mitsuba::phase_dict`)
evaluated by Mitsuba equal `pnsolver.phase_value`, and the integrator's reading of Mitsuba's
phase functions (`pnsolver.mitsuba.phase_settings_of`) gives the same function back.

Needs Mitsuba 3 (skips without it unless PN_REQUIRE_MITSUBA is set). Only `scalar_rgb`.

Tolerance. Mitsuba's `tabphase` is linear in cos θ between its nodes; the export puts an
irregular table and the droplet phase's Draine lobe on 4097 regular nodes (h = 2/4096). Linear
interpolation is off by at most h²/8 · max|p''| in a cell, which
`test_the_tabphase_resampling_error_is_small` evaluates for the Draine lobes (d = 5, 10, 50 µm)
and finds below 2e-5 of the value; an irregular table is exact except within one cell of its
own nodes (there h/4 · |slope jump|, 6e-4 relative for the table below, whose cosines lie
elsewhere). So the exported functions are within 1e-4 of pn's; the test allows 1e-3 relative
for Mitsuba's float32 evaluation, plus, near a sharp HG peak, float32's cancellation in
1 + g² − 2gμ: a relative error of about (3/2) ε₃₂ (1 + g²)/(1 + g² − 2gμ) (g = 0.998 for
d = 50 µm: 1e-2 at μ = 1), weighted by that lobe's share of the value.
"""

import math
import os

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba") if not os.environ.get("PN_REQUIRE_MITSUBA") else __import__("mitsuba")
import drjit as dr  # noqa: E402

import pnsolver  # noqa: E402

EPS32 = 2.0 ** -23

PHASES = {
    "isotropic": {"kind": "isotropic"},
    "hg": {"kind": "hg", "g": 0.8},
    "hg backward": {"kind": "hg", "g": -0.5},
    "two_term_hg": {"kind": "two_term_hg", "g1": 0.9, "g2": -0.3, "weight": 0.2},
    "tabulated": {"kind": "tabulated", "values": np.array([0.2, 0.5, 1.0, 4.0])},
    "tabulated, irregular": {"kind": "tabulated", "cos_theta": [-1.0, -0.3, 0.55, 1.0],
                             "values": [0.5, 0.6, 1.2, 4.0]},
    "droplet 5": {"kind": "droplet", "diameter": 5},
    "droplet 10": {"kind": "droplet", "diameter": 10},
    "droplet 50": {"kind": "droplet", "diameter": 50},
}

# 50 cosines: 30 over [-1, 0.9], 20 into the forward peak (μ = 1 included).
MU = np.concatenate([np.linspace(-1.0, 0.9, 30), 1.0 - np.geomspace(0.05, 1e-5, 19), [1.0]])


@pytest.fixture(scope="module")
def scalar():
    mi.set_variant("scalar_rgb")
    import pnsolver.mitsuba as pm
    return pm


def mitsuba_values(phase, mu):
    """Mitsuba's `eval_pdf` at the cosines `mu` between the travel directions before and
    after scattering: Mitsuba's wi points back to where the light came from, so the
    outgoing direction at cosine μ is wo with wo·(−wi) = μ (forward: wo = −wi)."""
    wi = mi.Vector3f(0.0, 0.0, 1.0)
    mei = dr.zeros(mi.MediumInteraction3f)
    mei.wi = wi
    mei.sh_frame = mi.Frame3f(wi)
    ctx = mi.PhaseFunctionContext(None)
    out = []
    for m in mu:
        s = math.sqrt(max(0.0, 1.0 - m * m))
        value, pdf = phase.eval_pdf(ctx, mei, mi.Vector3f(s, 0.0, -float(m)))
        assert abs(float(value[0]) - float(pdf)) <= 1e-6 * float(pdf)  # sampled exactly
        out.append(float(value[0]))
    return np.array(out)


def hg(g, mu):
    d = 1.0 + g * g - 2.0 * g * mu
    return (1.0 - g * g) / (4.0 * math.pi * d ** 1.5)


def hg_lobes(phase):
    """(share, g) of the HG lobes of a pn phase dict (for the float32 term)."""
    k = phase["kind"]
    if k == "hg":
        return [(1.0, phase["g"])]
    if k == "two_term_hg":
        return [(1.0 - phase["weight"], phase["g1"]), (phase["weight"], phase["g2"])]
    if k == "droplet":
        d = pnsolver.mitsuba_phase_dict(phase)  # blendphase(w_D, hg(g_HG), tabphase(Draine))
        return [(1.0 - d["weight"], d["phase1"]["g"])]
    return []


def tolerance(phase, mu, value):
    """1e-3 plus float32's cancellation near an HG peak (module docs), relative."""
    tol = np.full(len(mu), 1e-3)
    for share, g in hg_lobes(phase):
        d = 1.0 + g * g - 2.0 * g * mu
        tol += 1.5 * EPS32 * (1.0 + g * g) / d * share * hg(g, mu) / value
    return tol


@pytest.mark.parametrize("name", PHASES)
def test_mitsuba_evaluates_the_exported_phase_as_pnsolver_does(scalar, name):
    phase = PHASES[name]
    mitsuba = mi.load_dict(pnsolver.mitsuba_phase_dict(phase))
    ours = pnsolver.phase_value(phase, MU)
    theirs = mitsuba_values(mitsuba, MU)
    rel = np.abs(theirs / ours - 1.0)
    tol = tolerance(phase, MU, ours)
    assert np.all(rel <= tol), (name, MU[rel > tol], rel[rel > tol], tol[rel > tol])
    # Outside the last 1 % of the peak every cosine is held to 1e-3 itself.
    assert np.all(tol[MU <= 0.99] < 1.05e-3), tol


def test_the_tabphase_resampling_error_is_small():
    """h²/8 · max|p''| of the exported Draine lobes on their 4097 nodes, relative: the
    export's own error (module docs); h² p'' is the second difference of the values."""
    for d in (5, 10, 50):
        tab = pnsolver.mitsuba_phase_dict({"kind": "droplet", "diameter": d})["phase2"]
        v = np.array([float(x) for x in tab["values"].split(", ")])
        assert len(v) == 4097 and v[-1] > v[0]  # forward last
        bound = np.max(np.abs(np.diff(v, 2)) / 8.0 / v[1:-1])
        assert bound < 2e-5, (d, bound)


MITSUBA_PHASES = {
    "isotropic": ({"type": "isotropic"}, "isotropic"),
    "hg": ({"type": "hg", "g": 0.5}, "hg"),
    "blend of hg and isotropic": (
        {"type": "blendphase", "weight": 0.25, "phase1": {"type": "hg", "g": 0.5},
         "phase2": {"type": "isotropic"}}, "two_term_hg"),
    "blend of one hg twice": (
        {"type": "blendphase", "weight": 0.5, "phase1": {"type": "hg", "g": 0.5},
         "phase2": {"type": "hg", "g": 0.5}}, "hg"),
    "tabphase": ({"type": "tabphase", "values": "0.2, 0.5, 1.0, 4.0"}, "tabulated"),
    "nested blend with a tabphase": (
        {"type": "blendphase", "weight": 0.3, "phase1": {"type": "hg", "g": 0.95},
         "phase2": {"type": "blendphase", "weight": 0.5, "phase1": {"type": "isotropic"},
                    "phase2": {"type": "tabphase", "values": "0.1, 0.5, 1.0"}}},
        "tabulated"),
    "three hg lobes": (
        {"type": "blendphase", "weight": 0.4, "phase1": {"type": "hg", "g": 0.9},
         "phase2": {"type": "blendphase", "weight": 0.5, "phase1": {"type": "hg", "g": -0.6},
                    "phase2": {"type": "hg", "g": 0.2}}},
        "tabulated"),
}


@pytest.mark.parametrize("name", MITSUBA_PHASES)
def test_the_integrator_reads_mitsubas_phase_functions(scalar, name):
    d, kind = MITSUBA_PHASES[name]
    phase = mi.load_dict(d)
    ours = scalar.phase_settings_of(phase)
    assert ours["kind"] == kind, ours
    theirs = mitsuba_values(phase, MU)
    values = pnsolver.phase_value(ours, MU)
    rel = np.abs(values / theirs - 1.0)
    # Mitsuba's float32 against the resampled table's 3e-5 (module docs of mitsuba.py).
    assert rel.max() < 1e-3, (name, MU[rel.argmax()], rel.max())


@pytest.mark.parametrize("name", ["two_term_hg", "tabulated", "droplet 10", "droplet 50"])
def test_exported_phases_come_back_with_their_moments(scalar, name):
    """pn's export read back by the integrator: the same Legendre factors (the droplet as a
    resampled table: within 3e-5)."""
    phase = PHASES[name]
    back = scalar.phase_settings_of(mi.load_dict(pnsolver.mitsuba_phase_dict(phase)))
    m0 = pnsolver.phase_moments(phase, 12)
    m1 = pnsolver.phase_moments(back, 12)
    assert np.max(np.abs(m1 - m0)) < 3e-5, (name, back["kind"], m1 - m0)


@pytest.mark.parametrize("d, message", [
    ({"type": "blendphase", "weight": {"type": "gridvolume", "grid": "GRID"},
      "phase1": {"type": "hg", "g": 0.5}, "phase2": {"type": "isotropic"}},
     "weight must be a constant"),
    ({"type": "blendphase",
      "weight": {"type": "constvolume", "value": {"type": "rgb", "value": [0.1, 0.2, 0.3]}},
      "phase1": {"type": "hg", "g": 0.5}, "phase2": {"type": "isotropic"}},
     "weight must be grey"),
    ({"type": "rayleigh"}, "must be 'isotropic', 'hg', 'tabphase' or a 'blendphase'"),
    ({"type": "blendphase", "weight": 0.5, "phase1": {"type": "hg", "g": 0.5},
      "phase2": {"type": "rayleigh"}}, "got RayleighPhaseFunction"),
])
def test_phase_functions_it_cannot_read_are_refused(scalar, d, message):
    if d["type"] == "blendphase" and d["weight"] == {"type": "gridvolume", "grid": "GRID"}:
        d = dict(d, weight={"type": "gridvolume",
                            "grid": mi.VolumeGrid(np.full((2, 2, 2, 1), 0.5, dtype=np.float32))})
    with pytest.raises(ValueError, match=message):
        scalar.phase_settings_of(mi.load_dict(d))
