//! The Python extension module `pnsolver._pnsolver` (the `pnsolver` package re-exports it;
//! python/pnsolver/__init__.py documents the API for Python users).
//!
//! It exposes the library, not the command line: a [`Scene`] from a TOML file, a built-in
//! name or a settings dictionary with numpy density and albedo arrays; [`render`] and
//! [`solve`], which call [`pn_render::render_views`] with the interpreter lock
//! released and return numpy arrays and the report as a dictionary. Errors are `ValueError`s
//! with the messages of `pn render` (the scene parser's checks), naming the dictionary key,
//! the array or the figure (`input`: arrays are checked for dtype, shape and size before
//! anything is copied).

use input::{count, shape3, toml_error, FloatArray};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pn_render::RenderScene;
use pn_render::{render_views, ProgressCallback, RenderOptions, RenderRun};
use pyo3::exceptions::{PyImportError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

mod input;
mod phase;

/// An anyhow error as a Python `ValueError` with the whole chain of context.
fn value_error(e: anyhow::Error) -> PyErr {
    PyValueError::new_err(format!("{e:#}"))
}

/// A render scene (`pn render`'s TOML format): medium, phase, lights, camera, solve and
/// render settings.
#[pyclass(name = "Scene", module = "pnsolver", frozen)]
struct Scene {
    inner: RenderScene,
}

/// An environment map from a numpy array (height, width, 3) or (height, width), float64 or
/// float32, row 0 = +Y (Mitsuba's orientation); shape and size checked before copying.
fn envmap_array(a: &Bound<'_, PyAny>) -> PyResult<pn_render::sky::EnvMap> {
    let bad = |m: String| PyValueError::new_err(format!("envmap: {m}"));
    let shape: Vec<usize> = a
        .getattr("shape")
        .and_then(|s| s.extract())
        .map_err(|_| bad(format!("must be a numpy array, got {}", a.get_type())))?;
    let array = FloatArray::of("envmap", a)?;
    let (h, w) = match shape.as_slice() {
        [h, w] | [h, w, 3] => (*h, *w),
        _ => {
            return Err(bad(format!(
                "must have shape (height, width, 3) or (height, width), got {shape:?}"
            )))
        }
    };
    pn_render::sky::check_envmap_size(w, h).map_err(|e| bad(format!("{e:#}")))?;
    let values: Vec<f32> = array.to_vec(|v| v as f32);
    let texels: Vec<[f32; 3]> = if shape.len() == 2 {
        values.iter().map(|v| [*v; 3]).collect()
    } else {
        values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
    };
    pn_render::sky::EnvMap::new(w, h, texels).map_err(|e| bad(format!("{e:#}")))
}

/// The settings' `kind = "envmap"` light, made a placeholder `constant` light for the
/// parser (its map comes from the array): `file` and `radiance` refused. Returns the
/// light's number as the parser's messages name it (`light N`).
fn envmap_placeholder(table: &mut toml::Table) -> PyResult<usize> {
    let lights = table
        .get_mut("light")
        .and_then(|l| l.as_array_mut())
        .map(|l| {
            l.iter_mut()
                .filter_map(|l| l.as_table_mut())
                .collect::<Vec<_>>()
        })
        .unwrap_or_default();
    let mut found = None;
    for (n, l) in lights.into_iter().enumerate() {
        if l.get("kind").and_then(|k| k.as_str()) != Some("envmap") {
            continue;
        }
        for key in ["file", "radiance"] {
            if l.contains_key(key) {
                return Err(PyValueError::new_err(format!(
                    "an envmap array replaces the envmap light's {key}: leave {key} out"
                )));
            }
        }
        l.insert("kind".into(), toml::Value::String("constant".into()));
        l.insert("radiance".into(), toml::Value::Float(1.0));
        found = Some(n + 1);
    }
    found.ok_or_else(|| {
        PyValueError::new_err(
            "an envmap array needs a light of kind = \"envmap\" (without file) in settings",
        )
    })
}

/// The density array (and the albedo array) of `Scene(settings, density=…, albedo=…)`,
/// checked before they are copied (float64 or float32, rank 3, the same shape, no
/// zero-length axis, the copy within the memory limit), and the settings' medium made ready
/// for them: `medium.kind` left out or "grid", no file keys, `bbox_min` and `bbox_max`
/// given, `medium.resolution` left out or the array's shape; a placeholder procedural medium
/// of the array's size, which [`RenderScene::set_density_arrays`] replaces. Returns (shape,
/// density, albedo) in C order.
fn density_arrays(
    table: &mut toml::Table,
    density: &Bound<'_, PyAny>,
    albedo: Option<&Bound<'_, PyAny>>,
) -> PyResult<DensityArrays> {
    let d = FloatArray::of("density", density)?;
    let dims = shape3("density", &d)?;
    let a = albedo.map(|a| FloatArray::of("albedo", a)).transpose()?;
    if let Some(a) = &a {
        let adims = shape3("albedo", a)?;
        if adims != dims {
            return Err(PyValueError::new_err(format!(
                "albedo has shape {adims:?}, the density {dims:?}"
            )));
        }
    }
    input::check_size("density", dims, if a.is_some() { 2 } else { 1 })?;
    let medium = table
        .get_mut("medium")
        .and_then(|m| m.as_table_mut())
        .ok_or_else(|| PyValueError::new_err("settings need a \"medium\" section"))?;
    for key in ["file", "grid", "seed", "albedo_file", "albedo_grid"] {
        if medium.contains_key(key) {
            return Err(PyValueError::new_err(format!(
                "medium.{key} does not apply to a density array"
            )));
        }
    }
    for key in ["bbox_min", "bbox_max"] {
        if !medium.contains_key(key) {
            return Err(PyValueError::new_err(format!(
                "a density array needs medium.{key} (the box it covers)"
            )));
        }
    }
    if let Some(kind) = medium.get("kind").and_then(|k| k.as_str()) {
        if kind != "grid" {
            return Err(PyValueError::new_err(format!(
                "medium.kind {kind:?} with a density array: leave it out or say \"grid\""
            )));
        }
    }
    let res = toml::Value::Array(dims.map(|n| toml::Value::Integer(n as i64)).to_vec());
    if let Some(given) = medium.get("resolution") {
        if *given != res {
            return Err(PyValueError::new_err(format!(
                "medium.resolution {given} disagrees with the density array's shape {dims:?}; \
                 leave it out"
            )));
        }
    }
    if a.is_some() && !medium.contains_key("albedo") {
        // The array replaces it; the TOML check needs a value.
        medium.insert("albedo".into(), toml::Value::Float(0.0));
    }
    medium.insert("kind".into(), toml::Value::String("box".into()));
    medium.insert("resolution".into(), res);
    Ok((dims, d.to_vec(|v| v), a.map(|a| a.to_vec(|v| v))))
}

/// (shape, density, albedo) of [`density_arrays`].
type DensityArrays = ([usize; 3], Vec<f64>, Option<Vec<f64>>);

#[pymethods]
impl Scene {
    /// `Scene(settings, density=None, albedo=None, envmap=None)`: `settings` is the TOML
    /// scene as a dictionary (`{"medium": {...}, "phase": {...}, "light": [{...}],
    /// "camera": {...}, "solve": {...}, "render": {...}}`, keys as in the README). With
    /// `density` (a numpy array of shape (nx, ny, nz), x first, covering
    /// `medium.bbox_min`..`bbox_max`, which are then required) the medium is that array;
    /// `albedo` (same shape) replaces `medium.albedo`. With `envmap` (a numpy array (height,
    /// width, 3) or (height, width), 2:1, row 0 = +Y as Mitsuba's `envmap`) the map of the
    /// scene's `kind = "envmap"` light, which then has no `file`. Values may be numpy arrays
    /// and scalars (the phase's `values`, …). Bad input is a `ValueError` naming the key (as
    /// a path, `settings.solve.order`), the array or the figure.
    #[new]
    #[pyo3(signature = (settings, density = None, albedo = None, envmap = None))]
    fn new(
        settings: &Bound<'_, PyAny>,
        density: Option<&Bound<'_, PyAny>>,
        albedo: Option<&Bound<'_, PyAny>>,
        envmap: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let not_a_dict = || {
            let hint = if settings.is_instance_of::<pyo3::types::PyString>() {
                " (Scene.load reads a built-in scene or a TOML file)"
            } else {
                ""
            };
            PyValueError::new_err(format!(
                "settings must be a dictionary of the scene's sections ({{\"medium\": {{...}}, \
                 \"camera\": {{...}}, ...}}), got {}{hint}",
                settings.get_type()
            ))
        };
        if !settings.is_instance_of::<PyDict>() {
            return Err(not_a_dict());
        }
        let toml::Value::Table(mut table) = phase::to_toml(settings, "settings")? else {
            return Err(not_a_dict());
        };
        let envmap = envmap.map(envmap_array).transpose()?;
        let placeholder = match envmap {
            Some(_) => Some(envmap_placeholder(&mut table)?),
            None => None,
        };
        let arrays = match density {
            None if albedo.is_some() => {
                return Err(PyValueError::new_err(
                    "an albedo array needs a density array",
                ))
            }
            None => None,
            Some(d) => Some(density_arrays(&mut table, d, albedo)?),
        };
        let text = toml::to_string(&table).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let mut inner =
            RenderScene::from_toml_str(&text, std::path::Path::new(".")).map_err(|e| {
                if let Some(msg) = toml_error(&text, &e, "settings") {
                    return PyValueError::new_err(msg);
                }
                let mut msg = format!("{e:#}");
                if let Some(n) = placeholder {
                    // The parser saw the placeholder: name the light as the user wrote it.
                    msg = msg.replace(
                        &format!("light {n} (kind = \"constant\")"),
                        &format!("light {n} (kind = \"envmap\")"),
                    );
                }
                PyValueError::new_err(msg)
            })?;
        inner.name = "python".into();
        if let Some(map) = envmap {
            let mut sky = inner
                .sky
                .clone()
                .ok_or_else(|| PyValueError::new_err("the scene has no sky for the envmap"))?;
            sky.radiance = pn_render::sky::SkyRadiance::Map(std::sync::Arc::new(map));
            inner
                .set_sky(sky)
                .map_err(|e| value_error(e.context("envmap")))?;
        }
        if let Some((dims, data, albedo)) = arrays {
            inner
                .set_density_arrays(dims, data, albedo)
                .map_err(value_error)?;
        }
        Ok(Scene { inner })
    }

    /// A built-in render scene by name (`cloud`, `nebula`, `sphere`, `lowalbedo`) or a TOML
    /// scene file (relative paths in it resolved against its folder).
    #[staticmethod]
    fn load(scene: &str) -> PyResult<Self> {
        Ok(Scene {
            inner: RenderScene::load(scene).map_err(value_error)?,
        })
    }

    /// The grey scene of channel `c` (0, 1, 2 = R, G, B) of a coloured scene; a grey scene
    /// is its own channel.
    fn channel(&self, c: i64) -> PyResult<Self> {
        if !(0..=2).contains(&c) {
            return Err(PyValueError::new_err(format!(
                "channel must be 0, 1 or 2 (R, G, B), got {c}"
            )));
        }
        let c = c as usize;
        Ok(Scene {
            inner: self.inner.channel(c),
        })
    }

    /// Whether any value is given per channel (then `render` returns an RGB image).
    #[getter]
    fn coloured(&self) -> bool {
        self.inner.colours.is_some()
    }

    /// The scene's name (file stem, built-in name, or "python").
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    fn __repr__(&self) -> String {
        let s = &self.inner;
        format!(
            "Scene({:?}: {}×{} px, method {}, order {}, solve grid {:?}{})",
            s.name,
            s.camera.width,
            s.camera.height,
            s.solve.method.name(),
            s.solve.order,
            s.solve.resolution,
            if s.colours.is_some() {
                ", coloured"
            } else {
                ""
            }
        )
    }
}

/// Runs `render_views` on its own thread while this one waits with the interpreter lock
/// released, looking at Python's signals every 50 ms: Ctrl-C (KeyboardInterrupt) returns at
/// once. The interrupted solve cannot be stopped from outside; it finishes in the background
/// and its result is dropped. With `callback`, the solver's iterations travel back over a
/// channel and `callback(iteration, relative_residual)` is called for each on this thread,
/// with the lock held, at each 50 ms look; an exception it raises ends the wait like Ctrl-C.
fn run_interruptible(
    py: Python<'_>,
    scene: RenderScene,
    mut opts: RenderOptions,
    callback: Option<&Bound<'_, PyAny>>,
) -> PyResult<RenderRun> {
    use std::sync::mpsc::{channel, RecvTimeoutError};
    use std::sync::Mutex;
    let (events_tx, events) = channel::<(usize, f64)>();
    if callback.is_some() {
        let tx = Mutex::new(events_tx);
        opts.observer = Some(pn_runtime::solver::IterationObserver::new(
            move |it, rel| {
                // A receiver gone (the wait ended) or a poisoned lock only drop the report.
                if let Ok(tx) = tx.lock() {
                    let _ = tx.send((it, rel));
                }
            },
        ));
    }
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        // The receiver may be gone (interrupted); then the result is dropped.
        let _ = tx.send(render_views(&scene, &opts, 1));
    });
    let report = || -> PyResult<()> {
        if let Some(cb) = callback {
            for (it, rel) in events.try_iter() {
                cb.call1((it, rel))?;
            }
        }
        Ok(())
    };
    let mut rx = rx;
    loop {
        // The receiver moves into the lock-free section and back (it is Send, not Sync).
        let (received, back) = py.detach(move || {
            let r = rx.recv_timeout(std::time::Duration::from_millis(50));
            (r, rx)
        });
        rx = back;
        report()?;
        match received {
            Ok(result) => {
                let run = result.map_err(value_error)?;
                write_notes(py, &run.notes)?;
                return Ok(run);
            }
            Err(RecvTimeoutError::Timeout) => py.check_signals()?,
            Err(RecvTimeoutError::Disconnected) => {
                return Err(PyRuntimeError::new_err(
                    "the solve ended without a result (its thread panicked)",
                ))
            }
        }
    }
}

/// The run's notes (`warning: …`) on Python's `sys.stderr`, one line each, as `pn render`
/// prints them.
fn write_notes(py: Python<'_>, notes: &[String]) -> PyResult<()> {
    if notes.is_empty() {
        return Ok(());
    }
    let err = py.import("sys")?.getattr("stderr")?;
    for note in notes {
        err.call_method1("write", (format!("{note}\n"),))?;
    }
    Ok(())
}

/// The options of `render` and `solve`, checked: `threads` in 1..=`pn_runtime`'s
/// `max_threads` (the bound of `pn --threads`), `callback` callable.
fn options(
    threads: Option<i64>,
    progress: bool,
    callback: Option<&Bound<'_, PyAny>>,
) -> PyResult<RenderOptions> {
    if let Some(cb) = callback.filter(|cb| !cb.is_callable()) {
        return Err(PyValueError::new_err(format!(
            "callback must be callable as callback(iteration, relative_residual), got {}",
            cb.get_type()
        )));
    }
    let max_threads = pn_runtime::max_threads() as i64;
    Ok(RenderOptions {
        threads: threads
            .map(|t| count("threads", t, 1, Some(max_threads)))
            .transpose()?,
        progress,
        rows: progress.then(row_progress_bar),
        ..Default::default()
    })
}

/// A progress bar over the image rows ("image rows"), one per image, hidden unless stderr
/// is a terminal (what `progress=True` shows besides the solver's bar).
fn row_progress_bar() -> ProgressCallback {
    let bar: std::sync::Mutex<Option<indicatif::ProgressBar>> = std::sync::Mutex::new(None);
    ProgressCallback::new(move |done, total| {
        // A poisoned lock only loses the bar.
        let Ok(mut bar) = bar.lock() else {
            return;
        };
        if done == 0 {
            *bar = Some(new_bar(total));
            return;
        }
        if let Some(b) = bar.as_ref() {
            b.set_position(b.position().max(done as u64));
        }
        if done == total {
            if let Some(b) = bar.take() {
                b.finish_and_clear();
            }
        }
    })
}

/// An indicatif bar of `len` rows (indicatif draws it only when its target is a terminal).
fn new_bar(len: usize) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(len as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {pos} it  {msg}  ({per_sec})",
    ) {
        pb.set_style(style);
    }
    pb.set_message("image rows");
    pb
}

/// The run as a dictionary of numpy arrays and the report.
fn result_dict<'py>(py: Python<'py>, run: &RenderRun, image: bool) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    if image {
        let (w, h) = (run.image.width, run.image.height);
        let img = match &run.rgb {
            None => PyArray1::from_slice(py, &run.image.data)
                .reshape([h, w])?
                .into_any(),
            Some(rgb) => {
                let data: Vec<f32> = (0..w * h)
                    .flat_map(|i| rgb.image.each_ref().map(|c| c.data[i]))
                    .collect();
                PyArray1::from_vec(py, data).reshape([h, w, 3])?.into_any()
            }
        };
        d.set_item("image", img)?;
    }
    match &run.solution {
        Some(ms) => {
            let m = &ms.moments;
            let [nx, ny, nz] = m.res;
            let moments = PyArray1::from_slice(py, &m.data).reshape([nx, ny, nz, m.per_cell])?;
            let sqrt_4pi = (4.0 * std::f64::consts::PI).sqrt();
            let fluence: Vec<f64> = m.data.chunks(m.per_cell).map(|c| sqrt_4pi * c[0]).collect();
            let fluence = PyArray1::from_vec(py, fluence).reshape([nx, ny, nz])?;
            d.set_item("moments", moments)?;
            d.set_item("fluence", fluence)?;
            d.set_item("grid_min", ms.grid.min.to_vec())?;
            d.set_item("grid_max", ms.grid.max.to_vec())?;
            d.set_item("grid_res", ms.grid.res.to_vec())?;
        }
        None => {
            for key in ["moments", "fluence", "grid_min", "grid_max", "grid_res"] {
                d.set_item(key, py.None())?;
            }
        }
    }
    let report =
        serde_json::to_string(&run.report).map_err(|e| PyValueError::new_err(e.to_string()))?;
    d.set_item(
        "report",
        py.import("json")?.call_method1("loads", (report,))?,
    )?;
    Ok(d)
}

/// Solves and renders `scene`; returns a dict with `image` (numpy float32, shape (height,
/// width), or (height, width, 3) for a coloured scene; linear radiance), the solution
/// (`moments`, `fluence`, `grid_*`; see `solve`) and `report` (the `report.json` of
/// `pn render`). The interpreter lock is released while it runs; Ctrl-C raises
/// KeyboardInterrupt at once (the solve finishes in the background, its result dropped).
/// `callback(iteration, relative_residual)`, if given, is called for every iteration of the
/// solve (see `run_interruptible`).
#[pyfunction]
#[pyo3(signature = (scene, threads = None, progress = false, callback = None))]
fn render<'py>(
    py: Python<'py>,
    scene: &Scene,
    threads: Option<i64>,
    progress: bool,
    callback: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let run = run_interruptible(
        py,
        scene.inner.clone(),
        options(threads, progress, callback)?,
        callback,
    )?;
    result_dict(py, &run, true)
}

/// Solves the multiple scattering of a grey `scene` (the camera is not used: the image is
/// skipped); returns a dict with `moments` (float64, shape (nx, ny, nz, (N+1)²), x first,
/// last axis l(l+1)+m: the real-SH moments of the scattered radiance at the solve-cell
/// centres, the uncollided light excluded), `fluence` (√(4π)·moment 0, shape (nx, ny, nz)),
/// the solve grid's box `grid_min`, `grid_max` and `grid_res`, and `report`. With method
/// "none" the solution entries are None. `callback` as for `render`.
#[pyfunction]
#[pyo3(signature = (scene, threads = None, progress = false, callback = None))]
fn solve<'py>(
    py: Python<'py>,
    scene: &Scene,
    threads: Option<i64>,
    progress: bool,
    callback: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    if scene.inner.colours.is_some() {
        return Err(PyValueError::new_err(
            "a coloured scene has one solution per channel: solve scene.channel(0), (1) and (2)",
        ));
    }
    let mut s = scene.inner.clone();
    // One pixel: the render step costs nothing.
    s.camera.width = 1;
    s.camera.height = 1;
    let run = run_interruptible(py, s, options(threads, progress, callback)?, callback)?;
    result_dict(py, &run, false)
}

/// The real spherical harmonics Y_l^m (docs/design.md §2; `pn_stencil::quadrature::real_sh`)
/// of `directions` (real numbers, shape (n, 3), unit vectors) for l ≤ `lmax`: float64, shape
/// (n, (lmax+1)²), column l(l+1)+m. The reference the Mitsuba integrator's own evaluation is
/// tested against.
#[pyfunction]
fn real_sh<'py>(
    py: Python<'py>,
    lmax: i64,
    directions: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let lmax = count("lmax", lmax, 0, Some(64))?;
    let directions = input::real_array(directions, "directions")?.readonly();
    let shape = directions.shape().to_vec();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "directions must have shape (n, 3), got {shape:?}"
        )));
    }
    let d = directions.as_array();
    let per = (lmax + 1) * (lmax + 1);
    input::check_result_size("the result", shape[0] as u128 * per as u128)?;
    let mut out = Vec::with_capacity(shape[0] * per);
    for row in d.outer_iter() {
        let (x, y, z) = (row[0], row[1], row[2]);
        let norm = (x * x + y * y + z * z).sqrt();
        if !(norm.is_finite() && (norm - 1.0).abs() <= 1e-6) {
            return Err(PyValueError::new_err(format!(
                "directions must be unit vectors, got ({x}, {y}, {z})"
            )));
        }
        let (mu, phi) = (z.clamp(-1.0, 1.0), y.atan2(x));
        for l in 0..=lmax {
            for m in -(l as i64)..=(l as i64) {
                out.push(pn_stencil::quadrature::real_sh(l, m, mu, phi));
            }
        }
    }
    Ok(PyArray1::from_vec(py, out)
        .reshape([shape[0], per])?
        .into_any())
}

/// `_check_solve_settings(settings)`: checks a dictionary of `[solve]` keys as a scene's
/// `[solve]` table is checked (`pn_render::scene::solve_from_toml_str`: unknown keys, types,
/// ranges); a `ValueError` names the key. The Mitsuba integrator checks its properties with it
/// when it is created.
#[pyfunction]
#[pyo3(name = "_check_solve_settings")]
fn check_solve_settings(settings: &Bound<'_, PyAny>) -> PyResult<()> {
    if !settings.is_instance_of::<PyDict>() {
        return Err(PyValueError::new_err(
            "the solve settings must be a dictionary",
        ));
    }
    let toml::Value::Table(table) = phase::to_toml(settings, "solve")? else {
        return Err(PyValueError::new_err(
            "the solve settings must be a dictionary",
        ));
    };
    let text = toml::to_string(&table).map_err(|e| PyValueError::new_err(e.to_string()))?;
    pn_render::scene::solve_from_toml_str(&text).map_err(|e| {
        PyValueError::new_err(toml_error(&text, &e, "").unwrap_or_else(|| format!("{e:#}")))
    })?;
    Ok(())
}

/// The names of the built-in render scenes.
#[pyfunction]
fn builtin_scenes<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    PyList::new(py, pn_render::scene::builtin_names())
}

/// The module `pnsolver._pnsolver`.
#[pymodule]
fn _pnsolver(m: &Bound<'_, PyModule>) -> PyResult<()> {
    if let Some(message) = pn_runtime::missing_features() {
        return Err(PyImportError::new_err(message));
    }
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(builtin_scenes, m)?)?;
    m.add_function(wrap_pyfunction!(real_sh, m)?)?;
    m.add_function(wrap_pyfunction!(check_solve_settings, m)?)?;
    m.add_function(wrap_pyfunction!(phase::phase_moments, m)?)?;
    m.add_function(wrap_pyfunction!(phase::phase_value, m)?)?;
    m.add_function(wrap_pyfunction!(phase::mitsuba_phase_dict, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
