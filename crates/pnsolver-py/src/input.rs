//! The checks of what Python hands over, so that bad input is a `ValueError` naming the
//! argument, the key or the figure: numpy arrays (dtype and shape read, and their size
//! checked, before anything is copied), integers that must not be negative, and the TOML
//! errors of the text the binding writes from a dictionary, named by the dictionary's keys.

use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A float64 or float32 numpy array, borrowed (nothing copied yet).
pub(crate) enum FloatArray<'py> {
    F64(PyReadonlyArrayDyn<'py, f64>),
    F32(PyReadonlyArrayDyn<'py, f32>),
}

impl<'py> FloatArray<'py> {
    /// `a` if it is a numpy array of float64 or float32 (any layout: strided, transposed,
    /// broadcast), else a `ValueError`: "{name} must be a numpy array of float64 or float32,
    /// got {dtype}".
    pub(crate) fn of(name: &str, a: &Bound<'py, PyAny>) -> PyResult<Self> {
        if let Ok(x) = a.extract::<PyReadonlyArrayDyn<'py, f64>>() {
            return Ok(Self::F64(x));
        }
        if let Ok(x) = a.extract::<PyReadonlyArrayDyn<'py, f32>>() {
            return Ok(Self::F32(x));
        }
        let ty = a
            .getattr("dtype")
            .map(|d| d.to_string())
            .unwrap_or_else(|_| a.get_type().to_string());
        Err(PyValueError::new_err(format!(
            "{name} must be a numpy array of float64 or float32, got {ty}"
        )))
    }

    pub(crate) fn shape(&self) -> Vec<usize> {
        match self {
            Self::F64(x) => x.shape().to_vec(),
            Self::F32(x) => x.shape().to_vec(),
        }
    }

    /// The values in C order (the logical order whatever the strides), as `T`.
    pub(crate) fn to_vec<T: From<f32>>(&self, from64: impl Fn(f64) -> T) -> Vec<T> {
        match self {
            Self::F64(x) => x.as_array().iter().map(|v| from64(*v)).collect(),
            Self::F32(x) => x.as_array().iter().map(|v| T::from(*v)).collect(),
        }
    }
}

/// The shape (nx, ny, nz) of a float array of rank 3, refused otherwise.
pub(crate) fn shape3(name: &str, a: &FloatArray<'_>) -> PyResult<[usize; 3]> {
    let shape = a.shape();
    shape.as_slice().try_into().map_err(|_| {
        PyValueError::new_err(format!(
            "{name} must have shape (nx, ny, nz) (x first), got shape {shape:?}"
        ))
    })
}

/// Refuses `arrays` arrays of shape `dims` with a zero-length axis or whose copy would not
/// fit the default memory limit of a solve (`pn_render::scene::check_array_shape`), before
/// anything is copied.
pub(crate) fn check_size(name: &str, dims: [usize; 3], arrays: u32) -> PyResult<()> {
    let limit = pn_runtime::memory_estimate::default_limit_bytes();
    pn_render::scene::check_array_shape(name, dims, arrays, limit)
        .map_err(|e| PyValueError::new_err(format!("{e:#}")))
}

/// `obj` (a numpy array, a number or a sequence of numbers) as a float64 array; integers
/// are converted, other dtypes (bool, complex, strings, objects) refused naming `name`.
pub(crate) fn real_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let np = obj.py().import("numpy")?;
    let a = np
        .call_method1("asarray", (obj,))
        .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))?;
    let dtype = a.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "f" | "i" | "u") {
        return Err(PyValueError::new_err(format!(
            "{name} must hold real numbers (float or int), got dtype {dtype}"
        )));
    }
    let kwargs = pyo3::types::PyDict::new(obj.py());
    kwargs.set_item("copy", false)?;
    Ok(a.call_method("astype", ("float64",), Some(&kwargs))?
        .cast_into()?)
}

/// Refuses a result of `values` float64 values (`what` names it) that would exceed the
/// default memory limit of a solve, before it is allocated (a broadcast array in takes no
/// memory, the values computed from it would).
pub(crate) fn check_result_size(what: &str, values: u128) -> PyResult<()> {
    let limit = pn_runtime::memory_estimate::default_limit_bytes() as u128;
    let bytes = values.saturating_mul(8);
    if bytes > limit {
        use pn_runtime::memory_estimate::human_bytes;
        return Err(PyValueError::new_err(format!(
            "{what} would hold {values} values, about {}, more than the memory limit of {}",
            human_bytes(bytes),
            human_bytes(limit)
        )));
    }
    Ok(())
}

/// A count from Python that must lie in `min..=max` (`lmax`, `channel`, `threads`): an
/// integer of any sign is taken, so that a negative one is a `ValueError` naming it, not
/// pyo3's `OverflowError`.
pub(crate) fn count(name: &str, v: i64, min: i64, max: Option<i64>) -> PyResult<usize> {
    if v < min || max.is_some_and(|m| v > m) {
        let range = match max {
            Some(m) => format!("lie in {min}..={m}"),
            None => format!("be at least {min}"),
        };
        return Err(PyValueError::new_err(format!(
            "{name} must {range}, got {v}"
        )));
    }
    Ok(v as usize)
}

/// The message of `e` when it is a TOML error in `text`, which the binding wrote from a
/// dictionary: toml's message prefixed with the dictionary path of the key it is about
/// (`settings.solve.order: invalid type: string "3", expected a non-negative integer`)
/// instead of a line and column of a text the user never saw. `root` names the dictionary
/// ("" for none). None for other errors.
pub(crate) fn toml_error(text: &str, e: &anyhow::Error, root: &str) -> Option<String> {
    let te = e.downcast_ref::<toml::de::Error>()?;
    let msg = python_terms(te.message().trim_end());
    let path = te.span().map(|s| key_path(text, s)).unwrap_or_default();
    let full = match (root.is_empty(), path.is_empty()) {
        (true, true) => return Some(msg),
        (true, false) => path,
        (false, true) => root.to_string(),
        (false, false) => format!("{root}.{path}"),
    };
    Some(format!("{full}: {msg}"))
}

/// A serde message in the words of the Python values that made the TOML: `usize` as a
/// non-negative integer, maps as dictionaries, sequences as lists, the Rust name of a table's
/// struct (`expected struct PhaseToml`) as a dictionary.
fn python_terms(msg: &str) -> String {
    let mut m = msg
        .replace("expected usize", "expected a non-negative integer")
        .replace("expected u64", "expected a non-negative integer")
        .replace("expected f64", "expected a number")
        .replace("invalid type: map", "invalid type: dictionary")
        .replace("invalid type: sequence", "invalid type: list")
        .replace("expected a sequence", "expected a list");
    if let Some(at) = m.find("expected struct ") {
        let rest = &m[at + "expected struct ".len()..];
        let end = rest
            .find(|c: char| !c.is_alphanumeric() && c != '_')
            .unwrap_or(rest.len());
        m = format!("{}expected a dictionary{}", &m[..at], &rest[end..]);
    }
    m
}

/// The dotted key path of the place `span` of `text`, TOML as `toml::to_string` writes a
/// table: top-level keys, then `[section]` and `[[section]]` headers (the n-th `[[light]]`
/// as `light[n-1]`, as Python indexes the list), each followed by its `key = value` lines.
/// An empty span (an error about the whole document) has the empty path.
fn key_path(text: &str, span: std::ops::Range<usize>) -> String {
    if span.is_empty() {
        return String::new();
    }
    let at = span.start.min(text.len());
    let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    let raw = text[line_start..].lines().next().unwrap_or("");
    let line = raw.trim();
    // The table the line belongs to: the last header up to it (the line itself included).
    let mut table = String::new();
    let mut seen: Vec<(String, usize)> = Vec::new();
    for l in text[..line_start + raw.len()].lines().map(str::trim) {
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.strip_suffix("]]")) {
            let n = match seen.iter_mut().find(|(k, _)| k == name) {
                Some((_, n)) => {
                    *n += 1;
                    *n
                }
                None => {
                    seen.push((name.to_string(), 0));
                    0
                }
            };
            table = format!("{name}[{n}]");
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            if !l.contains('=') {
                table = name.to_string();
            }
        }
    }
    let key = (!line.starts_with('['))
        .then(|| line.split_once(" = "))
        .flatten()
        .map(|(k, _)| k.trim().trim_matches('"').to_string());
    match (table.is_empty(), key) {
        (_, None) => table,
        (true, Some(k)) => k,
        (false, Some(k)) => format!("{table}.{k}"),
    }
}
