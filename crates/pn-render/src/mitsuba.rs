//! Mitsuba 3 ground truth (docs/design.md §6, docs/rendering.md): the contents of a render
//! scene's export — a `.vol` density grid plus a Python script that builds the *same* scene
//! with `mi.load_dict` (variant `scalar_rgb`) and renders it with the `volpath` path tracer —
//! as values ([`export_files`], [`script_text`]). Writing them into a folder and running the
//! script with Python are the drivers' (`pn_drivers::mitsuba`).
//!
//! **How each convention maps** (every line checked against an independent deterministic
//! single-scattering integral on an asymmetric scene, see `tests/mitsuba_single_scatter.rs`
//! and docs/rendering.md, "Checked against Mitsuba"):
//!
//! * medium: a `cube` shape with a `null` BSDF covering the density box, holding a
//!   `heterogeneous` interior medium; `sigma_t` is a `gridvolume` with the scene's
//!   `filter_type` ([`super::DensityFilter`]: `"trilinear"`, Mitsuba's default and ours, or
//!   `"nearest"`; the convention, outer half voxel included, is the same as ours, see
//!   [`super::medium`]) and the default `wrap_mode = "clamp"`, whose unit cube is mapped
//!   onto the box by `to_world = translate(bbox_min)·scale(bbox_max − bbox_min)`
//!   (Mitsuba ignores the `.vol` header's box unless `use_grid_bbox` is set); `scale` is
//!   `sigma_t_scale`, `albedo` a float or a second `gridvolume` with the same filter
//!   (σ_s = albedo(x)·σ_t(x), both interpolated). A coloured scene
//!   ([`super::colour`]): a chromatic σ_t becomes a three-channel (RGB) `gridvolume` holding
//!   density × s_c / s_max with `scale` = s_max; a per-channel albedo and light strengths
//!   become `{"type": "rgb", "value": [r, g, b]}`;
//! * phase: Mitsuba's `hg` evaluates `1 + g² + 2g·(wi·wo)` with both directions pointing
//!   away from the vertex, i.e. `1 + g² − 2g μ` in the propagation-direction cosine μ of
//!   docs/design.md §2: the same function, g > 0 forward;
//! * lights: `directional` with `direction` = travel direction and `irradiance` = E;
//!   `point` with `intensity` = Φ/(4π);
//! * camera: `perspective` with `fov_axis = "x"` and `to_world = look_at(position, target,
//!   up)` gives exactly our rays (image x right, y down); `hdrfilm` with a `box` filter
//!   (each sample lands in its own pixel), RGB float32, written as EXR;
//! * integrator: `volpath` with `max_depth = -1` is full transport; `max_depth = 2` is
//!   single scattering only (camera ray, one medium vertex, one emitter connection; null
//!   boundary crossings do not count): the image is exactly linear in the albedo.

use super::medium::{DensityFilter, DensityGrid};
use super::scene::{Albedo, RenderScene};
use super::Light;
use crate::sky::{Sky, SkyRadiance};
use anyhow::{ensure, Context};
use pn_runtime::problem::Phase;
use std::fmt::Write as _;

/// The generated script's file name in the export folder.
pub const SCRIPT_FILE: &str = "render_mitsuba.py";
/// The density grid's file name in the export folder.
pub const DENSITY_FILE: &str = "density.vol";
/// The per-voxel albedo's file name (only for scenes with an albedo grid).
pub const ALBEDO_FILE: &str = "albedo.vol";
/// An environment map's file name in the export folder (scenes with an `envmap` sky).
pub const SKY_FILE: &str = "sky.exr";
/// The image the script writes by default.
pub const IMAGE_FILE: &str = "mitsuba.exr";
/// Environment variable naming the Python interpreter that has `mitsuba`.
pub const PYTHON_ENV: &str = "PN_MITSUBA_PYTHON";
/// The interpreter `scripts/mitsuba-venv.sh` creates, relative to the repository root.
pub const VENV_PYTHON: &str = ".venv-mitsuba/bin/python";
/// The Mitsuba version the script is written for (pinned in `scripts/mitsuba-venv.sh`).
pub const MITSUBA_VERSION: &str = "3.9.1";

/// What to write into the script (each can be overridden when the script runs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExportOptions {
    /// Samples per pixel.
    pub spp: usize,
    /// Sampler seed.
    pub seed: u64,
    /// `volpath` max_depth: −1 = all orders of scattering, 2 = single scattering only.
    pub max_depth: i64,
}

impl ExportOptions {
    /// The scene's `[render]` spp and seed, full transport.
    pub fn from_scene(scene: &RenderScene) -> Self {
        Self {
            spp: scene.render.spp,
            seed: scene.render.seed,
            max_depth: -1,
        }
    }

    /// Checks spp ≥ 1 and max_depth = −1 or ≥ 1.
    pub fn validate(&self) -> anyhow::Result<()> {
        ensure!(self.spp >= 1, "spp must be at least 1, got {}", self.spp);
        ensure!(
            self.max_depth == -1 || self.max_depth >= 1,
            "max_depth must be -1 (unlimited) or at least 1, got {}",
            self.max_depth
        );
        Ok(())
    }
}

/// The contents of an export folder, computed and not written ([`export_files`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ExportFiles {
    /// The bytes of [`DENSITY_FILE`] (`density.vol`).
    pub density: Vec<u8>,
    /// The bytes of [`ALBEDO_FILE`] (`albedo.vol`) where the albedo is a grid.
    pub albedo: Option<Vec<u8>>,
    /// The bytes of [`SKY_FILE`] (`sky.exr`) where the sky is an environment map.
    pub sky: Option<Vec<u8>>,
    /// The text of [`SCRIPT_FILE`] (`render_mitsuba.py`, [`script_text`]).
    pub script: String,
    /// The `filter_type` the script gives the grids (the scene's filter).
    pub filter: DensityFilter,
}

/// The files of the export of `scene` with `opts`: `density.vol` (and `albedo.vol` for an
/// albedo grid) and `render_mitsuba.py` (deterministic: the same scene and options give the
/// same bytes).
pub fn export_files(scene: &RenderScene, opts: &ExportOptions) -> anyhow::Result<ExportFiles> {
    opts.validate()?;
    let grid = scene.density_grid()?;
    let density = vol_bytes(&grid, &sigma_t_channels(scene).1);
    let albedo = match &scene.medium.albedo {
        Albedo::Constant(_) => None,
        Albedo::Voxels(v) => {
            let a = DensityGrid::new(grid.res, grid.bbox_min, grid.bbox_max, v.to_vec())
                .context("albedo grid")?
                .with_filter(grid.filter);
            Some(vol_bytes(&a, &[1.0]))
        }
    };
    let script = script_text(scene, &grid, opts)?;
    let sky = match scene.sky.as_ref().map(|s| &s.radiance) {
        Some(SkyRadiance::Map(m)) => {
            let (w, h) = m.size();
            let plane = |c: usize| m.texels().iter().map(|t| t[c]).collect::<Vec<f32>>();
            let (r, g, b) = (plane(0), plane(1), plane(2));
            Some(pn_formats::encode_exr_rgb(w, h, [&r, &g, &b])?)
        }
        _ => None,
    };
    Ok(ExportFiles {
        density,
        albedo,
        sky,
        script,
        filter: grid.filter,
    })
}

/// `grid` as the bytes of a `.vol` file with one channel per factor
/// ([`pn_formats::encode_vol_scaled`]).
fn vol_bytes(grid: &DensityGrid, factors: &[f64]) -> Vec<u8> {
    pn_formats::encode_vol_scaled(&grid.to_voxel_grid(), factors)
}

/// σ_t of the export: the `scale` of the medium and the factors of the density volume's
/// channels. Grey or achromatic σ_t: the scene's scale and one channel; chromatic σ_t (a
/// coloured scene): the largest channel scale and an RGB volume with density × s_c / s_max.
fn sigma_t_channels(scene: &RenderScene) -> (f64, Vec<f64>) {
    match &scene.colours {
        Some(c) if !c.achromatic_sigma_t() => {
            let s = c.sigma_t_scale;
            let max = s[0].max(s[1]).max(s[2]);
            (max, s.iter().map(|v| v / max).collect())
        }
        // The channel value itself: the grey field holds the channels' mean, which can
        // differ from it in the last bit.
        Some(c) => (c.sigma_t_scale[0], vec![1.0]),
        None => (scene.medium.sigma_t_scale, vec![1.0]),
    }
}

/// A Mitsuba spectrum: a float for a grey value, `{"type": "rgb", ...}` per channel.
fn spectrum(grey: f64, rgb: Option<[f64; 3]>) -> anyhow::Result<String> {
    match rgb {
        None => py(grey),
        Some(c) => Ok(format!("{{\"type\": \"rgb\", \"value\": {}}}", py3(c)?)),
    }
}

/// A Python float literal (exact round trip; finite values only).
fn py(x: f64) -> anyhow::Result<String> {
    ensure!(x.is_finite(), "cannot export the non-finite value {x}");
    Ok(format!("{x:?}"))
}

fn py3(v: [f64; 3]) -> anyhow::Result<String> {
    Ok(format!("[{}, {}, {}]", py(v[0])?, py(v[1])?, py(v[2])?))
}

/// Nodes of the regular `tabphase` grid that an irregular table or the droplet phase's
/// Draine lobe (smooth: g_D ≤ 0.65) is resampled onto.
pub const TABPHASE_NODES: usize = 4097;

/// Mitsuba's phase dictionary for `phase` (Python source). Henyey–Greenstein is `hg`; a
/// two-lobe blend is `blendphase` of two `hg` (`weight`: the second lobe's share, as
/// Mitsuba's); a tabulated phase is `tabphase`, whose values run over cos θ from −1
/// (backward) to 1 (forward) on a regular grid (checked against Mitsuba 3.6: the last value
/// is forward scattering): a regular table as given, an irregular one resampled on
/// [`TABPHASE_NODES`] nodes (its linear interpolant read there; exact where the table's nodes
/// fall on the grid). The droplet phase is `blendphase` of `hg(g_HG)` and a `tabphase` of the
/// Draine lobe on [`TABPHASE_NODES`] nodes (Mitsuba has no Draine lobe).
pub fn phase_dict(phase: &Phase) -> anyhow::Result<String> {
    let tab = |values: &[f64]| -> anyhow::Result<String> {
        let v: Vec<String> = values
            .iter()
            .map(|v| py(*v))
            .collect::<anyhow::Result<_>>()?;
        Ok(format!(
            "{{\"type\": \"tabphase\", \"values\": \"{}\"}}",
            v.join(", ")
        ))
    };
    let hg = |g: f64| -> anyhow::Result<String> {
        Ok(format!("{{\"type\": \"hg\", \"g\": {}}}", py(g)?))
    };
    let grid = |n: usize| (0..n).map(move |i| -1.0 + 2.0 * i as f64 / (n - 1) as f64);
    Ok(match phase {
        Phase::Isotropic => "{\"type\": \"isotropic\"}".to_string(),
        Phase::HenyeyGreenstein(g) => hg(*g)?,
        Phase::TwoTermHg { g1, g2, weight } => format!(
            "{{\"type\": \"blendphase\", \"weight\": {}, \"phase1\": {}, \"phase2\": {}}}",
            py(*weight)?,
            hg(*g1)?,
            hg(*g2)?
        ),
        Phase::Tabulated(t) => {
            if t.is_regular() {
                tab(t.values())?
            } else {
                let v: Vec<f64> = grid(TABPHASE_NODES).map(|mu| t.value(mu)).collect();
                tab(&v)?
            }
        }
        Phase::Droplet(d) => {
            let v: Vec<f64> = grid(TABPHASE_NODES)
                .map(|mu| pn_runtime::phase::draine(d.g_draine, d.alpha, mu))
                .collect();
            format!(
                "{{\"type\": \"blendphase\", \"weight\": {}, \"phase1\": {}, \"phase2\": {}}}",
                py(d.w_draine)?,
                hg(d.g_hg)?,
                tab(&v)?
            )
        }
        Phase::DeltaM(_) => anyhow::bail!(
            "internal: a delta-M truncated phase is the solve's, not a scene's; export the scene's phase"
        ),
    })
}

/// Whether `p` lies strictly inside the box (the camera then starts in the medium).
fn inside(p: [f64; 3], min: [f64; 3], max: [f64; 3]) -> bool {
    (0..3).all(|d| p[d] > min[d] && p[d] < max[d])
}

/// The text of `render_mitsuba.py` for `scene` with the density `grid` (deterministic:
/// the same scene and options give the same bytes). The `gridvolume`s use `grid.filter`
/// (the scene's [`super::MediumSpec::filter`] when `grid` is [`RenderScene::density_grid`]);
/// the script's header, its `FILTER` constant and its JSON output name it.
pub fn script_text(
    scene: &RenderScene,
    grid: &DensityGrid,
    opts: &ExportOptions,
) -> anyhow::Result<String> {
    opts.validate()?;
    let m = &scene.medium;
    ensure!(
        m.sigma_t_scale.is_finite() && m.sigma_t_scale >= 0.0,
        "sigma_t_scale must be finite and non-negative"
    );
    let colours = scene.colours.as_ref();
    let albedo = match (&m.albedo, colours.and_then(|c| c.albedo)) {
        (Albedo::Constant(a), rgb) => spectrum(*a, rgb)?,
        (Albedo::Voxels(_), _) => format!("grid(\"{ALBEDO_FILE}\")"),
    };
    let strength = |i: usize, grey: f64, factor: f64| {
        spectrum(
            grey * factor,
            colours.map(|c| c.light_strength[i].map(|v| v * factor)),
        )
    };
    let phase = phase_dict(&scene.phase)?;
    let mut emitters = String::new();
    for (i, light) in scene.lights.iter().enumerate() {
        let body = match light {
            Light::Directional {
                direction,
                irradiance,
            } => format!(
                "{{\"type\": \"directional\", \"direction\": {}, \"irradiance\": {}}}",
                py3(*direction)?,
                strength(i, *irradiance, 1.0)?
            ),
            Light::Point { position, power } => format!(
                "{{\"type\": \"point\", \"position\": {}, \"intensity\": {}}}",
                py3(*position)?,
                strength(i, *power, 1.0 / (4.0 * std::f64::consts::PI))?
            ),
        };
        writeln!(emitters, "        \"light{i}\": {body},")?;
    }
    if let Some(sky) = &scene.sky {
        writeln!(emitters, "        \"sky\": {},", sky_dict(sky)?)?;
    }
    let c = &scene.camera;
    let sensor_medium = if inside(c.position, grid.bbox_min, grid.bbox_max) {
        "\n            \"medium\": {\"type\": \"ref\", \"id\": \"medium\"},"
    } else {
        ""
    };
    let fill = |t: &str| -> anyhow::Result<String> {
        Ok(t.replace("@NAME@", &scene.name)
            .replace("@VERSION@", MITSUBA_VERSION)
            .replace("@FILTER@", grid.filter.name())
            .replace("@SPP@", &opts.spp.to_string())
            .replace("@SEED@", &opts.seed.to_string())
            .replace("@MAX_DEPTH@", &opts.max_depth.to_string())
            .replace(
                "@HIDE_EMITTERS@",
                if scene.render.hide_emitters {
                    "True"
                } else {
                    "False"
                },
            )
            .replace("@BBOX_MIN@", &py3(grid.bbox_min)?)
            .replace("@BBOX_MAX@", &py3(grid.bbox_max)?)
            .replace("@SCALE@", &py(sigma_t_channels(scene).0)?)
            .replace("@ALBEDO@", &albedo)
            .replace("@PHASE@", &phase)
            .replace("@EMITTERS@", emitters.trim_end())
            .replace("@ORIGIN@", &py3(c.position)?)
            .replace("@TARGET@", &py3(c.target)?)
            .replace("@UP@", &py3(c.up)?)
            .replace("@FOV@", &py(c.fov_deg)?)
            .replace("@WIDTH@", &c.width.to_string())
            .replace("@HEIGHT@", &c.height.to_string())
            .replace("@SENSOR_MEDIUM@", sensor_medium))
    };
    fill(TEMPLATE)
}

/// A sky as a Mitsuba emitter: `constant` with its radiance, or `envmap` reading
/// [`SKY_FILE`] with `scale` and `to_world` (the rotation as a 4 × 4 matrix).
fn sky_dict(sky: &Sky) -> anyhow::Result<String> {
    let rgb = |c: [f64; 3]| -> anyhow::Result<String> {
        Ok(format!("{{\"type\": \"rgb\", \"value\": {}}}", py3(c)?))
    };
    Ok(match &sky.radiance {
        SkyRadiance::Constant(c) => format!(
            "{{\"type\": \"constant\", \"radiance\": {}}}",
            rgb(c.map(|v| v * sky.scale))?
        ),
        SkyRadiance::Map(_) => {
            let m = &sky.to_world;
            let mut rows = Vec::new();
            for r in m {
                rows.push(format!(
                    "[{}, {}, {}, 0.0]",
                    py(r[0])?,
                    py(r[1])?,
                    py(r[2])?
                ));
            }
            rows.push("[0.0, 0.0, 0.0, 1.0]".into());
            format!(
                "{{\"type\": \"envmap\", \"filename\": os.path.join(HERE, \"{SKY_FILE}\"), \
                 \"scale\": {}, \"to_world\": T([{}])}}",
                py(sky.scale)?,
                rows.join(", ")
            )
        }
    })
}

/// The script template (`mitsuba/render_scene.py`, a Python file with `@KEY@` placeholders
/// that [`script_text`] fills).
const TEMPLATE: &str = include_str!("mitsuba/render_scene.py");

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::Command;

    fn scene() -> RenderScene {
        RenderScene::builtin("lowalbedo").unwrap()
    }

    #[test]
    fn script_is_deterministic_and_carries_the_scene() {
        let s = scene();
        let g = s.density_grid().unwrap();
        let o = ExportOptions::from_scene(&s);
        let a = script_text(&s, &g, &o).unwrap();
        assert_eq!(a, script_text(&s, &g, &o).unwrap());
        assert!(!a.contains('@'), "unfilled placeholder");
        // Point light: intensity Φ/(4π); directional: irradiance and travel direction.
        assert!(a.contains(&format!(
            "\"intensity\": {:?}",
            30.0 / (4.0 * std::f64::consts::PI)
        )));
        assert!(a.contains("\"type\": \"hg\", \"g\": 0.4"));
        assert!(a.contains("\"fov_axis\": \"x\""));
        // The scene's filter (default trilinear), named in the header too.
        assert!(a.contains("\"filter_type\": FILTER"));
        assert!(a.contains("FILTER = \"trilinear\""));
        assert!(a.contains("Density filter: trilinear"));
        let n = script_text(&s, &g.clone().with_filter(DensityFilter::Nearest), &o).unwrap();
        assert!(n.contains("FILTER = \"nearest\"") && n.contains("Density filter: nearest"));
        assert!(a.contains("\"scale\": 6.0"));
        // The camera is outside the medium box: no sensor medium.
        assert!(!a.contains("\"medium\": {\"type\": \"ref\""));
    }

    /// The filled template is valid Python (checked with `python3 -m py_compile` where a
    /// `python3` is on the PATH; skipped otherwise).
    #[test]
    fn generated_script_compiles_as_python() {
        let s = scene();
        let g = s.density_grid().unwrap();
        let text = script_text(&s, &g, &ExportOptions::from_scene(&s)).unwrap();
        let dir = std::env::temp_dir().join(format!("pn-mitsuba-pycompile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(SCRIPT_FILE);
        std::fs::write(&path, text).unwrap();
        let out = Command::new("python3")
            .args(["-m", "py_compile"])
            .arg(&path)
            .output();
        let _ = std::fs::remove_dir_all(&dir);
        match out {
            Ok(o) => assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr)),
            Err(_) => eprintln!("no python3: skipped"),
        }
    }

    #[test]
    fn camera_inside_the_medium_gets_the_medium() {
        let mut s = scene();
        s.camera.position = [0.0, 0.1, 0.0];
        let g = s.density_grid().unwrap();
        let a = script_text(&s, &g, &ExportOptions::from_scene(&s)).unwrap();
        assert!(a.contains("\"medium\": {\"type\": \"ref\", \"id\": \"medium\"},"));
    }

    #[test]
    fn bad_options_are_refused() {
        let s = scene();
        let g = s.density_grid().unwrap();
        let mut o = ExportOptions::from_scene(&s);
        o.max_depth = 0;
        assert!(script_text(&s, &g, &o).is_err());
        o.max_depth = 2;
        o.spp = 0;
        assert!(script_text(&s, &g, &o).is_err());
    }

    /// The `"values": "a, b, …"` strings of the `tabphase`s in a dict, parsed.
    fn tab_values(dict: &str) -> Vec<Vec<f64>> {
        dict.split("\"type\": \"tabphase\", \"values\": \"")
            .skip(1)
            .map(|rest| {
                let end = rest.find('"').unwrap();
                rest[..end]
                    .split(", ")
                    .map(|v| v.parse::<f64>().unwrap())
                    .collect()
            })
            .collect()
    }

    #[test]
    fn phase_dicts_have_mitsubas_structure_for_every_kind() {
        use pn_runtime::phase::{draine, DropletPhase, TabulatedPhase};
        use std::sync::Arc;
        assert_eq!(
            phase_dict(&Phase::Isotropic).unwrap(),
            "{\"type\": \"isotropic\"}"
        );
        assert_eq!(
            phase_dict(&Phase::hg(-0.25).unwrap()).unwrap(),
            "{\"type\": \"hg\", \"g\": -0.25}"
        );
        // Two lobes: blendphase, weight = the second lobe's share, phase1 = the first lobe.
        assert_eq!(
            phase_dict(&Phase::two_term_hg(0.8, -0.4, 0.25).unwrap()).unwrap(),
            "{\"type\": \"blendphase\", \"weight\": 0.25, \
             \"phase1\": {\"type\": \"hg\", \"g\": 0.8}, \
             \"phase2\": {\"type\": \"hg\", \"g\": -0.4}}"
        );
        // A regular table: its values as given, normalised (Mitsuba normalises too).
        let t = TabulatedPhase::new(None, vec![0.0, 0.5, 1.0]).unwrap();
        let d = phase_dict(&Phase::Tabulated(Arc::new(t.clone()))).unwrap();
        assert!(
            d.starts_with("{\"type\": \"tabphase\", \"values\": \""),
            "{d}"
        );
        assert_eq!(tab_values(&d), vec![t.values().to_vec()]);
        // An irregular table: resampled on the regular grid of TABPHASE_NODES, the last
        // node forward (μ = 1).
        let t = TabulatedPhase::new(Some(vec![-1.0, 0.3, 1.0]), vec![1.0, 2.0, 5.0]).unwrap();
        let d = phase_dict(&Phase::Tabulated(Arc::new(t.clone()))).unwrap();
        let v = &tab_values(&d)[0];
        assert_eq!(v.len(), TABPHASE_NODES);
        assert_eq!(v[0], t.value(-1.0));
        assert_eq!(v[TABPHASE_NODES - 1], t.value(1.0));
        assert_eq!(v[(TABPHASE_NODES - 1) / 2], t.value(0.0));
        // The droplet phase: blendphase(weight = w_D, hg(g_HG), tabphase(Draine lobe)).
        let dp = DropletPhase::new(10.0).unwrap();
        let d = phase_dict(&Phase::Droplet(dp)).unwrap();
        let head = format!(
            "{{\"type\": \"blendphase\", \"weight\": {:?}, \"phase1\": {{\"type\": \"hg\", \
             \"g\": {:?}}}, \"phase2\": {{\"type\": \"tabphase\", \"values\": \"",
            dp.w_draine, dp.g_hg
        );
        assert!(d.starts_with(&head), "{}", &d[..200]);
        assert!(d.ends_with("\"}}"));
        let v = &tab_values(&d)[0];
        assert_eq!(v.len(), TABPHASE_NODES);
        assert_eq!(v[0], draine(dp.g_draine, dp.alpha, -1.0));
        assert_eq!(v[TABPHASE_NODES - 1], draine(dp.g_draine, dp.alpha, 1.0));
        assert!(v[TABPHASE_NODES - 1] > v[0]);
        // A truncated phase is the solve's, never exported.
        let (trunc, _) = Phase::hg(0.9).unwrap().delta_m(3);
        assert!(phase_dict(&trunc).is_err());
        // The script carries the dict.
        let mut s = scene();
        s.phase = Phase::two_term_hg(0.8, -0.4, 0.25).unwrap();
        let g = s.density_grid().unwrap();
        let text = script_text(&s, &g, &ExportOptions::from_scene(&s)).unwrap();
        assert!(text.contains(&phase_dict(&s.phase).unwrap()));
    }

    #[test]
    fn export_files_hold_a_vol_that_decodes_and_the_script() {
        let s = scene();
        let o = ExportOptions::from_scene(&s);
        let e = export_files(&s, &o).unwrap();
        let back = pn_formats::decode_vol(&e.density).unwrap();
        let g = s.density_grid().unwrap();
        assert_eq!(back.dims, g.res);
        let [i, j, k] = [3, 17, 25];
        assert_eq!(back.at(i, j, k) as f32, g.data[g.index(i, j, k)]);
        assert!(e.albedo.is_none());
        assert_eq!(e.script, script_text(&s, &g, &o).unwrap());
        assert_eq!(e, export_files(&s, &o).unwrap());
    }
}
