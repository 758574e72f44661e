//! The TOML representation of a render scene and its translation into a [`RenderScene`]
//! (unknown keys refused, parse errors with line and column, `--set` overrides applied to
//! the table first).

use super::validate::{finite3, nonneg};
use super::voxels::{albedo_voxels, read_albedo_file, read_grid_file};
use super::*;
use crate::camera::{norm, Camera};
use crate::colour::{Colours, GreyOrRgb};
use crate::lights::Light;
use crate::medium::{
    check_box, check_procedural_resolution, DensityFilter, DensityGrid, Procedural,
};
use crate::scene_override::SceneOverride;
use crate::sky::{rotation_to_up, Sky, SkyRadiance};
use anyhow::{bail, ensure, Context};
use pn_runtime::phase::{DropletPhase, TabulatedPhase};
use pn_runtime::problem::Phase;
use pn_runtime::scene_registry::{self, SceneKind};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

// ---- TOML representation ----

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneToml {
    medium: MediumToml,
    phase: Option<PhaseToml>,
    #[serde(default)]
    light: Vec<LightToml>,
    camera: CameraToml,
    solve: Option<SolveToml>,
    render: Option<RenderToml>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct MediumToml {
    kind: String,
    file: Option<PathBuf>,
    grid: Option<String>,
    seed: Option<u64>,
    resolution: Option<[usize; 3]>,
    bbox_min: Option<[f64; 3]>,
    bbox_max: Option<[f64; 3]>,
    sigma_t_scale: GreyOrRgb,
    albedo: Option<GreyOrRgb>,
    albedo_file: Option<PathBuf>,
    albedo_grid: Option<String>,
    filter: Option<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct PhaseToml {
    kind: String,
    g: Option<f64>,
    g1: Option<f64>,
    g2: Option<f64>,
    weight: Option<f64>,
    values: Option<Vec<f64>>,
    cos_theta: Option<Vec<f64>>,
    diameter: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct LightToml {
    kind: String,
    direction: Option<[f64; 3]>,
    irradiance: Option<GreyOrRgb>,
    position: Option<[f64; 3]>,
    power: Option<GreyOrRgb>,
    file: Option<PathBuf>,
    radiance: Option<GreyOrRgb>,
    scale: Option<f64>,
    up: Option<[f64; 3]>,
    to_world: Option<[[f64; 3]; 3]>,
    directions: Option<usize>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct CameraToml {
    position: [f64; 3],
    target: [f64; 3],
    up: [f64; 3],
    fov: f64,
    width: usize,
    height: usize,
}

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct SolveToml {
    method: Option<RenderMethod>,
    order: Option<usize>,
    resolution: Option<[usize; 3]>,
    margin: Option<usize>,
    absorbing_layer: Option<usize>,
    absorber_width: Option<f64>,
    absorber: Option<AbsorberPlacement>,
    boundary: Option<SolveBoundary>,
    tolerance: Option<f64>,
    sigma_t_min: Option<f64>,
    fld_solver: Option<FldSolver>,
    pop_resolution: Option<usize>,
    pop_iterations: Option<usize>,
    pop_residuum: Option<bool>,
    pop_epsilon_a: Option<f64>,
    pop_epsilon_l: Option<f64>,
    pop_shells: Option<usize>,
    pop_upsample: Option<PopUpsample>,
    pop_upsample_sigma: Option<f64>,
    sweeps: Option<usize>,
    sweep_quadrature: Option<usize>,
    sweep_acceleration: Option<bool>,
    sweep_scheme: Option<SweepScheme>,
    sweep_order: Option<usize>,
    delta_m: Option<bool>,
    similarity: Option<bool>,
    sweep_bands: Option<usize>,
}

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct RenderToml {
    renderer: Option<RendererKind>,
    spp: Option<usize>,
    seed: Option<u64>,
    rays: Option<usize>,
    step: Option<f64>,
    cutoff: Option<f64>,
    exact_transmittance: Option<bool>,
    hide_emitters: Option<bool>,
    sky_grid: Option<f64>,
    ms_lookup: Option<MsLookup>,
}

impl RenderScene {
    /// Reads and checks a scene file (errors name the file, and the line and column for
    /// syntax and type errors).
    pub fn from_path(path: &Path) -> anyhow::Result<RenderScene> {
        Self::from_path_with_overrides(path, &[])
    }

    /// [`RenderScene::from_path`] with `--set` overrides applied to the file's TOML before it
    /// is checked ([`RenderScene::from_toml_str_with_overrides`]). The name is the file stem.
    pub fn from_path_with_overrides(
        path: &Path,
        overrides: &[SceneOverride],
    ) -> anyhow::Result<RenderScene> {
        let text = pn_formats::read_text(path)
            .with_context(|| format!("cannot read scene file {}", path.display()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut scene =
            Self::from_toml_str_with_overrides(&text, base, overrides).with_context(|| {
                match crate::scene_kind::toml_kind(&text) {
                    Some(SceneKind::Solve) => format!(
                        "scene file {} ({})",
                        path.display(),
                        scene_registry::wrong_kind_file_hint(path, SceneKind::Solve)
                    ),
                    _ => format!("scene file {}", path.display()),
                }
            })?;
        if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
            scene.name = stem.to_string();
        }
        Ok(scene)
    }

    /// Parses and checks a scene from TOML text; relative paths are resolved against
    /// `base_dir`. The name is "scene" (see [`RenderScene::from_path`]).
    pub fn from_toml_str(s: &str, base_dir: &Path) -> anyhow::Result<RenderScene> {
        Self::from_toml_str_with_overrides(s, base_dir, &[])
    }

    /// [`RenderScene::from_toml_str`] with `--set` overrides: the text must be a valid scene
    /// on its own (its errors keep their line and column); then each override is applied to
    /// its TOML table in order ([`SceneOverride::apply`]) and the result is read and checked
    /// as if it had been written in the file. An unknown key or a wrong type is refused with
    /// the field's name and the `--set` that introduced it; a value the checks refuse gets the
    /// overrides as context.
    pub fn from_toml_str_with_overrides(
        s: &str,
        base_dir: &Path,
        overrides: &[SceneOverride],
    ) -> anyhow::Result<RenderScene> {
        // toml's Display names the line and column and quotes the offending line; the error
        // keeps its type (`toml::de::Error`, with the span) for callers that name the key
        // instead (the Python binding, whose TOML text the user never saw).
        let t: SceneToml = toml::from_str(s)?;
        if overrides.is_empty() {
            return build(t, base_dir);
        }
        let pristine: toml::Table = toml::from_str(s).map_err(|e| anyhow::anyhow!("{e}"))?;
        let all = || {
            overrides
                .iter()
                .map(|o| o.text.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let read = |table: &toml::Table| -> Result<SceneToml, String> {
            toml::Value::Table(table.clone())
                .try_into::<SceneToml>()
                .map_err(|e| e.message().trim_end().to_string())
        };
        let mut table = pristine.clone();
        for o in overrides {
            o.apply(&mut table)?;
        }
        let t = match read(&table) {
            Ok(t) => t,
            Err(e) => {
                // Name the override that gives this very error on its own, if one does.
                for o in overrides {
                    let mut one = pristine.clone();
                    o.apply(&mut one)?;
                    if read(&one).err().as_deref() == Some(e.as_str()) {
                        bail!("--set {o}: {e}");
                    }
                }
                bail!("--set {}: {e}", all())
            }
        };
        build(t, base_dir).with_context(|| format!("with --set {}", all()))
    }
}

/// The grey value of a per-channel value: the mean of its channels (a coloured scene's grey
/// fields hold these; it is rendered channel by channel, [`RenderScene::channel`]).
pub(super) fn channel_mean(v: GreyOrRgb) -> f64 {
    match v {
        GreyOrRgb::Grey(x) => x,
        GreyOrRgb::Rgb(c) => (c[0] + c[1] + c[2]) / 3.0,
    }
}

/// A light and its strength (irradiance or power) as given, grey or per channel.
pub(super) fn build_light(l: LightToml, n: usize) -> anyhow::Result<(Light, GreyOrRgb)> {
    let ctx = || format!("light {} (kind = {:?})", n + 1, l.kind);
    if let Some(k) = [
        ("file", l.file.is_some()),
        ("radiance", l.radiance.is_some()),
        ("scale", l.scale.is_some()),
        ("up", l.up.is_some()),
        ("to_world", l.to_world.is_some()),
        ("directions", l.directions.is_some()),
    ]
    .into_iter()
    .find_map(|(k, set)| set.then_some(k))
    {
        bail!(
            "{}: {k} applies to sky lights (kind = \"envmap\" or \"constant\")",
            ctx()
        );
    }
    match l.kind.as_str() {
        "directional" => {
            ensure!(
                l.position.is_none() && l.power.is_none(),
                "{}: position and power apply to point lights",
                ctx()
            );
            let d = l
                .direction
                .with_context(|| format!("{}: needs direction", ctx()))?;
            let e = l
                .irradiance
                .with_context(|| format!("{}: needs irradiance", ctx()))?;
            finite3("direction", d).with_context(ctx)?;
            let len = norm(d);
            ensure!(len > 0.0, "{}: direction must not be zero", ctx());
            for v in e.channels() {
                nonneg("irradiance", v).with_context(ctx)?;
            }
            let light = Light::Directional {
                direction: d.map(|c| c / len),
                irradiance: channel_mean(e),
            };
            Ok((light, e))
        }
        "point" => {
            ensure!(
                l.direction.is_none() && l.irradiance.is_none(),
                "{}: direction and irradiance apply to directional lights",
                ctx()
            );
            let p = l
                .position
                .with_context(|| format!("{}: needs position", ctx()))?;
            let w = l.power.with_context(|| format!("{}: needs power", ctx()))?;
            finite3("position", p).with_context(ctx)?;
            for v in w.channels() {
                nonneg("power", v).with_context(ctx)?;
            }
            let light = Light::Point {
                position: p,
                power: channel_mean(w),
            };
            Ok((light, w))
        }
        k => bail!(
            "light {}: unknown kind {k:?} (expected directional, point, envmap or constant)",
            n + 1
        ),
    }
}

/// A sky light: `kind = "envmap"` with `file` (relative to the scene file), or
/// `kind = "constant"` with `radiance`; optional `scale`, `up` or `to_world` (a rotation,
/// rows) and `directions` ([`crate::sky`]).
fn build_sky(l: LightToml, n: usize, base: &Path) -> anyhow::Result<Sky> {
    let ctx = || format!("light {} (kind = {:?})", n + 1, l.kind);
    if let Some(k) = [
        ("direction", l.direction.is_some()),
        ("irradiance", l.irradiance.is_some()),
        ("position", l.position.is_some()),
        ("power", l.power.is_some()),
    ]
    .into_iter()
    .find_map(|(k, set)| set.then_some(k))
    {
        bail!("{}: {k} applies to directional or point lights", ctx());
    }
    let mut sky = if l.kind == "envmap" {
        ensure!(
            l.radiance.is_none(),
            "{}: radiance applies to kind = \"constant\" (an envmap's radiance is its file; \
             use scale)",
            ctx()
        );
        let file = l
            .file
            .with_context(|| format!("{}: needs file (a latitude–longitude EXR)", ctx()))?;
        let path = base.join(&file);
        let map = crate::sky::read_envmap(&path).with_context(ctx)?;
        let mut s = Sky::constant([0.0; 3]);
        s.radiance = SkyRadiance::Map(Arc::new(map));
        s.file = Some(path);
        s
    } else {
        ensure!(
            l.file.is_none(),
            "{}: file applies to kind = \"envmap\"",
            ctx()
        );
        let r = l
            .radiance
            .with_context(|| format!("{}: needs radiance", ctx()))?;
        let c = r.channels();
        for v in c {
            nonneg("radiance", v).with_context(ctx)?;
        }
        Sky::constant(c)
    };
    if let Some(s) = l.scale {
        sky.scale = s;
    }
    ensure!(
        !(l.up.is_some() && l.to_world.is_some()),
        "{}: give up or to_world, not both",
        ctx()
    );
    if let Some(up) = l.up {
        sky.to_world = rotation_to_up(up).with_context(ctx)?;
    }
    if let Some(m) = l.to_world {
        sky.to_world = m;
    }
    if let Some(k) = l.directions {
        sky.directions = k;
    }
    sky.validate().with_context(ctx)?;
    Ok(sky)
}

/// A phase function from a `[phase]` table of the scene format (`kind` and the keys of that
/// kind: `g`; `g1`, `g2`, `weight`; `values`, `cos_theta`; `diameter`), checked as in a scene
/// file: unknown keys, keys of another kind and bad values are refused with the key's name.
/// The Python binding reads its phase dictionaries with it.
pub fn phase_from_table(table: toml::Table) -> anyhow::Result<Phase> {
    let p: PhaseToml = toml::Value::Table(table)
        .try_into()
        .map_err(|e: toml::de::Error| anyhow::anyhow!("{}", e.message().trim_end()))?;
    build_phase(p)
}

/// The `[phase]` table: `kind` and the keys of that kind, no others.
fn build_phase(p: PhaseToml) -> anyhow::Result<Phase> {
    let given: Vec<&str> = [
        ("g", p.g.is_some()),
        ("g1", p.g1.is_some()),
        ("g2", p.g2.is_some()),
        ("weight", p.weight.is_some()),
        ("values", p.values.is_some()),
        ("cos_theta", p.cos_theta.is_some()),
        ("diameter", p.diameter.is_some()),
    ]
    .into_iter()
    .filter_map(|(k, set)| set.then_some(k))
    .collect();
    let allowed: &[&str] = match p.kind.as_str() {
        "isotropic" => &[],
        "hg" => &["g"],
        "two_term_hg" => &["g1", "g2", "weight"],
        "tabulated" => &["values", "cos_theta"],
        "droplet" => &["diameter"],
        k => {
            bail!("unknown kind {k:?} (expected isotropic, hg, two_term_hg, tabulated or droplet)")
        }
    };
    if let Some(k) = given.iter().find(|k| !allowed.contains(k)) {
        bail!(
            "{k} does not apply to kind = {:?} (its keys: {})",
            p.kind,
            if allowed.is_empty() {
                "none".to_string()
            } else {
                allowed.join(", ")
            }
        );
    }
    let need =
        |v: Option<f64>, key: &str| v.with_context(|| format!("kind = {:?} needs {key}", p.kind));
    Ok(match p.kind.as_str() {
        "isotropic" => Phase::Isotropic,
        "hg" => Phase::hg(need(p.g, "g")?)?,
        "two_term_hg" => Phase::two_term_hg(
            need(p.g1, "g1")?,
            need(p.g2, "g2")?,
            need(p.weight, "weight")?,
        )?,
        "tabulated" => {
            let values = p
                .values
                .context("kind = \"tabulated\" needs values (over cos θ from -1 to 1)")?;
            Phase::Tabulated(std::sync::Arc::new(TabulatedPhase::new(
                p.cos_theta,
                values,
            )?))
        }
        _ => Phase::Droplet(DropletPhase::new(need(p.diameter, "diameter")?)?),
    })
}

/// The `[solve]` settings from the keys of a `[solve]` table written as a TOML document
/// (`order = 3` …, defaults for the keys left out), checked as in a scene file: unknown keys,
/// wrong types ([`toml::de::Error`], with the span) and values out of range are refused. The
/// Python binding checks the Mitsuba integrator's properties with it.
pub fn solve_from_toml_str(s: &str) -> anyhow::Result<SolveSettings> {
    build_solve(toml::from_str(s)?)
}

/// The `[solve]` table's settings, defaults filled in, checked ([`SolveSettings::validate`]).
fn build_solve(s: SolveToml) -> anyhow::Result<SolveSettings> {
    let solve = SolveSettings {
        method: s.method.unwrap_or(RenderMethod::Pn),
        order: s.order.unwrap_or(3),
        resolution: s.resolution.unwrap_or([32; 3]),
        margin: s.margin.unwrap_or(DEFAULT_MARGIN),
        absorber_width: s.absorber_width.unwrap_or(DEFAULT_ABSORBER_WIDTH),
        absorbing_layer: s.absorbing_layer,
        absorber: s.absorber.unwrap_or_default(),
        boundary: s.boundary.unwrap_or_default(),
        tolerance: s.tolerance.unwrap_or(DEFAULT_RENDER_TOLERANCE),
        sigma_t_min: s.sigma_t_min.filter(|v| *v != 0.0),
        fld_solver: s.fld_solver.unwrap_or_default(),
        pop_resolution: s.pop_resolution.unwrap_or(POP_DEFAULT_RESOLUTION),
        pop_iterations: s.pop_iterations.unwrap_or(POP_DEFAULT_ITERATIONS),
        pop_residuum: s.pop_residuum.unwrap_or(false),
        pop_epsilon_a: s.pop_epsilon_a.unwrap_or(POP_DEFAULT_EPSILON_A),
        pop_epsilon_l: s.pop_epsilon_l.unwrap_or(POP_DEFAULT_EPSILON_L),
        pop_shells: s.pop_shells,
        pop_upsample: s.pop_upsample.unwrap_or_default(),
        pop_upsample_sigma: s.pop_upsample_sigma.unwrap_or(POP_DEFAULT_UPSAMPLE_SIGMA),
        sweeps: s.sweeps.unwrap_or(DEFAULT_SWEEPS),
        sweep_quadrature: s.sweep_quadrature,
        sweep_acceleration: s.sweep_acceleration.unwrap_or(false),
        sweep_scheme: s.sweep_scheme.unwrap_or_default(),
        sweep_order: s.sweep_order,
        delta_m: s.delta_m.unwrap_or(true),
        similarity: s.similarity.unwrap_or(false),
        sweep_bands: s.sweep_bands,
    };
    solve.validate()?;
    Ok(solve)
}

pub(super) fn build(t: SceneToml, base: &Path) -> anyhow::Result<RenderScene> {
    let (sigma_t_scale, albedo) = (t.medium.sigma_t_scale, t.medium.albedo);
    let medium = build_medium(t.medium, base).context("[medium]")?;
    let phase = match t.phase {
        None => Phase::Isotropic,
        Some(p) => build_phase(p).context("[phase]")?,
    };
    let mut sky: Option<Sky> = None;
    let mut own = Vec::new();
    for (n, l) in t.light.into_iter().enumerate() {
        if matches!(l.kind.as_str(), "envmap" | "constant") {
            ensure!(
                sky.is_none(),
                "light {}: a scene has at most one sky (kind = \"envmap\" or \"constant\")",
                n + 1
            );
            sky = Some(build_sky(l, n, base)?);
        } else {
            own.push(build_light(l, n)?);
        }
    }
    let (lights, strengths): (Vec<Light>, Vec<GreyOrRgb>) = own.into_iter().unzip();
    let coloured = sigma_t_scale.is_rgb()
        || albedo.is_some_and(|a| a.is_rgb())
        || strengths.iter().any(|s| s.is_rgb())
        || sky.as_ref().is_some_and(Sky::is_rgb);
    let colours = coloured.then(|| Colours {
        sigma_t_scale: sigma_t_scale.channels(),
        albedo: albedo.map(|a| a.channels()),
        light_strength: strengths.iter().map(|s| s.channels()).collect(),
    });
    let c = t.camera;
    let camera = Camera {
        position: c.position,
        target: c.target,
        up: c.up,
        fov_deg: c.fov,
        width: c.width,
        height: c.height,
    };
    camera.validate().context("[camera]")?;
    let solve = build_solve(t.solve.unwrap_or_default()).context("[solve]")?;
    let r = t.render.unwrap_or_default();
    let render = RenderSettings {
        renderer: r.renderer.unwrap_or_default(),
        spp: r.spp.unwrap_or(64),
        seed: r.seed.unwrap_or(1),
        rays: r.rays.unwrap_or(DEFAULT_RAYS),
        step: r.step.unwrap_or(DEFAULT_STEP),
        cutoff: r.cutoff.unwrap_or(DEFAULT_CUTOFF),
        exact_transmittance: r.exact_transmittance.unwrap_or(false),
        ms_lookup: r.ms_lookup.unwrap_or_default(),
        hide_emitters: r.hide_emitters.unwrap_or(false),
        sky_grid: r.sky_grid.unwrap_or(DEFAULT_SKY_GRID),
    };
    render.validate().context("[render]")?;
    Ok(RenderScene {
        name: "scene".into(),
        medium,
        phase,
        lights,
        sky,
        sky_lights: None,
        colours,
        camera,
        solve,
        render,
    })
}

pub(super) fn build_medium(m: MediumToml, base: &Path) -> anyhow::Result<MediumSpec> {
    for v in m.sigma_t_scale.channels() {
        nonneg("medium.sigma_t_scale", v)?;
    }
    for (n, v) in [
        ("medium.bbox_min", m.bbox_min),
        ("medium.bbox_max", m.bbox_max),
    ] {
        if let Some(v) = v {
            finite3(n, v)?;
        }
    }
    let seed = m.seed.unwrap_or(0);
    let mut density_vdb = None;
    let (source, resolution, bbox_min, bbox_max) = match m.kind.as_str() {
        "grid" => {
            let file = m
                .file
                .context("medium.kind = \"grid\" needs medium.file (a .vol, .npy or .vdb file)")?;
            ensure!(
                m.seed.is_none(),
                "medium.seed applies to procedural media only"
            );
            let path = base.join(&file);
            let gf = read_grid_file(&path, m.grid.as_deref()).context("medium.file")?;
            density_vdb = gf.vdb;
            let (vg, has_box) = (gf.voxels, gf.placed);
            if let Some(r) = m.resolution {
                ensure!(
                    r == vg.dims,
                    "medium.resolution {r:?} disagrees with the grid file's {:?}; leave it out",
                    vg.dims
                );
            }
            let (dmin, dmax) = if has_box {
                (vg.min, vg.max)
            } else {
                DEFAULT_BBOX
            };
            let bmin = m.bbox_min.unwrap_or(dmin);
            let bmax = m.bbox_max.unwrap_or(dmax);
            let grid = DensityGrid::from_voxel_grid(&vg, bmin, bmax)
                .with_context(|| format!("density file {}", path.display()))?;
            let res = grid.res;
            (
                MediumSource::File {
                    path,
                    grid: Arc::new(grid),
                },
                res,
                bmin,
                bmax,
            )
        }
        other => {
            let p = match other {
                "sphere" => Procedural::Sphere,
                "box" => Procedural::Box,
                "cloud" => Procedural::Cloud,
                "nebula" => Procedural::Nebula,
                _ => bail!(
                    "unknown medium.kind {other:?} (expected grid, sphere, box, cloud or nebula)"
                ),
            };
            ensure!(
                m.file.is_none() && m.grid.is_none(),
                "medium.file and medium.grid apply to kind = \"grid\" only"
            );
            let res = m.resolution.unwrap_or([64; 3]);
            check_procedural_resolution(res)?;
            (
                MediumSource::Procedural(p),
                res,
                m.bbox_min.unwrap_or(DEFAULT_BBOX.0),
                m.bbox_max.unwrap_or(DEFAULT_BBOX.1),
            )
        }
    };
    check_box(bbox_min, bbox_max).context("medium")?;
    let filter = match &m.filter {
        None => DensityFilter::default(),
        Some(f) => f.parse::<DensityFilter>().context("medium.filter")?,
    };
    ensure!(
        m.albedo_grid.is_none() || m.albedo_file.is_some(),
        "medium.albedo_grid needs medium.albedo_file (a .vdb file)"
    );
    let albedo = match (m.albedo, m.albedo_file) {
        (Some(_), Some(_)) => bail!("give medium.albedo or medium.albedo_file, not both"),
        (None, None) => bail!("medium.albedo (or medium.albedo_file) is required"),
        (Some(a), None) => {
            for a in a.channels() {
                ensure!(
                    a.is_finite() && (0.0..=1.0).contains(&a),
                    "medium.albedo must lie in [0, 1], got {a}"
                );
            }
            Albedo::Constant(channel_mean(a))
        }
        (None, Some(f)) => {
            let path = base.join(&f);
            let vg = read_albedo_file(&path, m.albedo_grid.as_deref(), density_vdb.as_ref())
                .context("medium.albedo_file")?;
            ensure!(
                vg.dims == resolution,
                "albedo file {} has resolution {:?}, the density grid {:?}",
                path.display(),
                vg.dims,
                resolution
            );
            albedo_voxels(&vg, bbox_min, bbox_max)
                .with_context(|| format!("albedo file {}", path.display()))?
        }
    };
    Ok(MediumSpec {
        source,
        seed,
        resolution,
        bbox_min,
        bbox_max,
        sigma_t_scale: channel_mean(m.sigma_t_scale),
        albedo,
        filter,
    })
}
