//! Python values as TOML (the scene settings and phase dictionaries, numpy arrays allowed)
//! and the phase functions of the scene format from Python: `phase_moments`, `phase_value`
//! and `mitsuba_phase_dict`.

use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pn_runtime::problem::Phase;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

/// The largest band `phase_moments` computes (a guard against a typo, far above any P_N
/// order in use).
const MAX_LMAX: usize = 4096;

/// A Python value as a TOML value: bool, int, float, str, dict (string keys), list or tuple,
/// and anything with `tolist()` (numpy arrays and scalars) as what that returns. `path`
/// names the value in errors (`settings.phase.values`).
pub(crate) fn to_toml(obj: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        let i: i64 = obj.extract().map_err(|_| {
            PyValueError::new_err(format!("{path}: the integer {obj} is too large"))
        })?;
        return Ok(toml::Value::Integer(i));
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(obj.extract()?));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(obj.extract()?));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, v) in d.iter() {
            let key: String = k.extract().map_err(|_| {
                PyValueError::new_err(format!("{path}: the keys must be strings, got {k:?}"))
            })?;
            let value = to_toml(&v, &format!("{path}.{key}"))?;
            t.insert(key, value);
        }
        return Ok(toml::Value::Table(t));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let items = obj
            .try_iter()?
            .enumerate()
            .map(|(i, v)| to_toml(&v?, &format!("{path}[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(toml::Value::Array(items));
    }
    if obj.is_none() {
        return Err(PyValueError::new_err(format!(
            "{path}: None is not a value (leave the key out)"
        )));
    }
    if obj.hasattr("tolist")? {
        // numpy: an array becomes (nested) lists, a scalar a Python number.
        return to_toml(&obj.call_method0("tolist")?, path);
    }
    Err(PyValueError::new_err(format!(
        "{path}: expected a number, string, list, dictionary or numpy array, got {}",
        obj.get_type()
    )))
}

/// The phase function of a dictionary with the keys of the scene format's `[phase]` table
/// (`{"kind": "hg", "g": 0.8}`, `{"kind": "droplet", "diameter": 10}`, …; numpy arrays for
/// `values` and `cos_theta`), checked as in a scene file.
pub(crate) fn phase_of(phase: &Bound<'_, PyAny>) -> PyResult<Phase> {
    let d = phase.cast::<PyDict>().map_err(|_| {
        PyValueError::new_err(format!(
            "the phase must be a dictionary such as {{\"kind\": \"hg\", \"g\": 0.8}}, got {}",
            phase.get_type()
        ))
    })?;
    let toml::Value::Table(t) = to_toml(d.as_any(), "phase")? else {
        return Err(PyValueError::new_err("the phase must be a dictionary"));
    };
    pn_render::scene::phase_from_table(t)
        .map_err(|e| PyValueError::new_err(format!("phase: {e:#}")))
}

/// `phase_moments(phase, lmax)`: the Funk–Hecke factors λ_l p_l = 2π ∫ p(μ) P_l(μ) dμ for
/// l = 0..=lmax (float64, length lmax + 1; g^l for Henyey–Greenstein), as the solver uses
/// them.
#[pyfunction]
pub(crate) fn phase_moments<'py>(
    py: Python<'py>,
    phase: &Bound<'py, PyAny>,
    lmax: i64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let lmax = crate::input::count("lmax", lmax, 0, Some(MAX_LMAX as i64))?;
    let p = phase_of(phase)?;
    let m: Vec<f64> = (0..=lmax as u32).map(|l| p.moment(l)).collect();
    Ok(PyArray1::from_vec(py, m))
}

/// `phase_value(phase, mu)`: p(μ) (float64, the shape of `mu`), normalised over the sphere
/// (2π ∫ p dμ = 1), μ the cosine between the direction light travelled before the scattering
/// and after it (μ = 1: forward). `mu`: a number or an array of cosines in [−1, 1].
#[pyfunction]
pub(crate) fn phase_value<'py>(
    py: Python<'py>,
    phase: &Bound<'py, PyAny>,
    mu: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = phase_of(phase)?;
    let a = crate::input::real_array(mu, "mu")?.readonly();
    let shape = a.shape().to_vec();
    crate::input::check_result_size("the result", a.len() as u128)?;
    let values = a
        .as_array()
        .iter()
        .map(|&m| {
            if m.is_finite() && m.abs() <= 1.0 + 1e-12 {
                Ok(p.value(m))
            } else {
                Err(PyValueError::new_err(format!(
                    "mu must hold cosines in [-1, 1], got {m}"
                )))
            }
        })
        .collect::<PyResult<Vec<f64>>>()?;
    Ok(PyArray1::from_vec(py, values).reshape(shape)?.into_any())
}

/// `mitsuba_phase_dict(phase)`: the Mitsuba 3 dictionary `pn export-mitsuba` writes for the
/// phase (`hg`, `blendphase` of two `hg`, `tabphase`, the droplet phase as `blendphase` of
/// `hg` and a `tabphase` of its Draine lobe; `pn_render::mitsuba::phase_dict`), for
/// `mi.load_dict`.
#[pyfunction]
pub(crate) fn mitsuba_phase_dict<'py>(
    py: Python<'py>,
    phase: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = phase_of(phase)?;
    let source =
        pn_render::mitsuba::phase_dict(&p).map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
    py.import("ast")?.call_method1("literal_eval", (source,))
}
