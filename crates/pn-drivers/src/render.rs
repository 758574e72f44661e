//! `pn render <scene.toml | builtin>`: solves the multiple scattering of a render scene on
//! its (cropped, possibly coarser) solve grid and renders the image (docs/rendering.md). Writes `image.exr` (linear), `image.png` (tone-mapped) and
//! `report.json` (times, unknowns with and without cropping and at the density resolution,
//! solver statistics, peak memory).
//!
//! The pieces live in `pn_render`; this module only picks the stencil (P_N or
//! CDA through `pn_kernels`, FLD through [`super::fld_method`]; POP, which needs no
//! stencil, through [`pn_render::pop`]) and runs the chain.

use crate::fld_setup::{fld_problem, solve_fld_route, FldSettings, SQRT_4PI};
use crate::scene_setup::Route;
use anyhow::{bail, ensure, Context, Result};
use pn_formats::image_io::{write_exr_gray, write_png_tonemapped};
use pn_kernels::{cda_kernel, diffusion_kernel, pn_kernel, Dim, KernelChoice, Staggering};
use pn_render::first_scatter::first_scatter_problem_with_depth;
use pn_render::light_depth::LightDepth;
use pn_render::march::{MarchSettings, Marcher};
use pn_render::pop::{pop_field, PopReport, PopSettings, ResiduumSettings};
use pn_render::renderer::{Image, MsField, Renderer};
use pn_render::scene::{FldSolver, RenderMethod, RendererKind};
use pn_render::shadow::Extinction;
use pn_render::solve_setup::solve_grid;
use pn_render::transport_sweep::{transport_sweeps, SweepSettings};
use pn_render::{Camera, DensityFilter, DensityGrid, RenderScene, SceneOverride};
use pn_runtime::fld::{FldParams, Limiter};
use pn_runtime::memory_estimate;
use pn_runtime::pipeline::solve_problem_from;
use pn_runtime::problem::Grid;
use pn_runtime::solver::multigrid::FineCycle;
use pn_runtime::solver::{SolverKind, SolverOptions, SolverTuning};
use pn_runtime::unstagger::CellMoments;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

pub mod rgb;

/// The options of `pn render`: the scene and the overrides of its settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderRequest {
    /// A scene file (`.toml`) or a built-in scene: cloud, nebula, sphere, lowalbedo.
    pub scene: String,
    /// Multiple scattering: pn, cda, fld, or none (default: the scene's).
    pub method: Option<RenderMethod>,
    /// P_N order (method pn), highest band handed to the renderer (method pop); default:
    /// the scene's.
    pub order: Option<usize>,
    /// Method pop: cells along the longest axis of each light-aligned grid (default: the
    /// scene's `[solve] pop_resolution`).
    pub pop_resolution: Option<usize>,
    /// Method pop: propagation iterations (default: the scene's `[solve] pop_iterations`).
    pub pop_iterations: Option<usize>,
    /// Method pop: use the isotropic residuum (§5.4; or the scene's `[solve] pop_residuum`).
    pub pop_residuum: bool,
    /// Method pop, residuum: ε_a (default: the scene's `[solve] pop_epsilon_a`).
    pub pop_epsilon_a: Option<f64>,
    /// Method pop, residuum: ε_L (default: the scene's `[solve] pop_epsilon_l`).
    pub pop_epsilon_l: Option<f64>,
    /// Transport sweeps after the solve (default: the scene's `[solve] sweeps`).
    pub sweeps: Option<usize>,
    /// Samples per pixel of the Monte Carlo renderer (default: the scene's).
    pub spp: Option<usize>,
    /// The renderer (default: the scene's, deterministic unless it says otherwise).
    pub renderer: Option<RendererKind>,
    /// Camera rays per pixel of the deterministic renderer, k² (default: the scene's).
    pub rays: Option<usize>,
    /// Step of the deterministic renderer in voxel sides (default: the scene's).
    pub step: Option<f64>,
    /// Deterministic renderer: exact transmittance to the lights at every step.
    pub exact_transmittance: bool,
    /// Density filter, overriding the scene's `[medium] filter`.
    pub filter: Option<DensityFilter>,
    /// Render K views of one solve around the target ([`turntable_camera`]).
    pub turntable: Option<usize>,
    /// Solve-grid cells across the medium box: one number for all axes or three.
    pub solve_res: Option<Vec<usize>>,
    /// Output directory (default `out/render-<scene>`).
    pub out: Option<PathBuf>,
    /// Print the unknowns with and without cropping and at the density resolution.
    pub stats: bool,
    /// Also write `moments.npy` (the solution at the solve-cell centres, shape (nx, ny, nz,
    /// (N+1)²)); grey scenes with a solve only.
    pub save_moments: bool,
    /// `--set SECTION.KEY=VALUE` overrides of the scene's TOML, applied in order before the
    /// scene is checked (and before the other options here).
    pub set: Vec<SceneOverride>,
    /// Threads, memory limit, progress bars and solver tuning.
    pub options: RenderOptions,
    /// Solve this PDE text file (docs/pde-text.md) for the multiple scattering instead of
    /// the scene's method.
    pub pde: Option<PathBuf>,
    /// `NAME=VALUE` overrides of the PDE file's `param`s.
    pub pde_params: Vec<(String, String)>,
}

impl Default for RenderRequest {
    /// The `nebula` scene with its own settings.
    fn default() -> Self {
        Self {
            scene: "nebula".into(),
            method: None,
            order: None,
            pop_resolution: None,
            pop_iterations: None,
            pop_residuum: false,
            pop_epsilon_a: None,
            pop_epsilon_l: None,
            sweeps: None,
            spp: None,
            renderer: None,
            rays: None,
            step: None,
            exact_transmittance: false,
            filter: None,
            turntable: None,
            solve_res: None,
            out: None,
            stats: false,
            save_moments: false,
            set: Vec::new(),
            options: RenderOptions::default(),
            pde: None,
            pde_params: Vec::new(),
        }
    }
}

/// How [`render_scene`] runs (not what it renders).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// Refuse solves whose estimated memory exceeds this many bytes (default: 80% of the
    /// physical memory).
    pub max_memory: Option<u64>,
    /// Show progress bars (drawn only when stderr is a terminal).
    pub progress: bool,
    /// Expert solver settings (the `pn` binary reads them from the environment).
    pub tuning: SolverTuning,
    /// A text PDE solved for the multiple scattering instead of the scene's method
    /// ([`RenderRequest::pde`]; the first-scatter source up to the highest band Q_l^m the PDE
    /// reads, the radiance moments of the solution handed to the renderer).
    pub pde: Option<std::sync::Arc<crate::pde_text::PdeKernel>>,
    /// Called after every iteration of the P_N / CDA / text-PDE solves (per channel of a
    /// coloured scene, counting from 1 each time); FLD's Gauss–Seidel solve is not observed.
    pub observer: Option<pn_runtime::solver::IterationObserver>,
}

impl Default for RenderOptions {
    /// All cores, the default memory limit, progress bars, tuned solver defaults.
    fn default() -> Self {
        Self {
            threads: None,
            max_memory: None,
            progress: true,
            tuning: SolverTuning::default(),
            pde: None,
            observer: None,
        }
    }
}

/// Unknowns of the solve (what cropping and a coarse grid save; docs/solvers.md).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UnknownStats {
    /// Solved: the cropped grid at the solve resolution.
    pub solved: u128,
    /// The whole medium box (plus margin) at the solve resolution.
    pub uncropped: u128,
    /// The cropped grid at the density-grid resolution.
    pub cropped_at_density_resolution: u128,
    /// The whole box at the density-grid resolution.
    pub uncropped_at_density_resolution: u128,
    /// Solve-grid cells per axis (cropped).
    pub solve_grid_res: [usize; 3],
    /// Solve-grid box.
    pub solve_grid_min: [f64; 3],
    /// Solve-grid box.
    pub solve_grid_max: [f64; 3],
}

/// Seconds per stage.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Timings {
    /// Building the density grid.
    pub density: f64,
    /// Resampling σ_t, σ_s and projecting the first-scatter source.
    pub sources: f64,
    /// Assembly + linear (or FLD) solve.
    pub solve: f64,
    /// The transport sweeps after the solve ([`RenderReport::sweeps`]).
    pub sweeps: f64,
    /// The optical depth from the medium to the lights ([`LightDepth`]: light-frame planes
    /// for directional lights, voxel centres near the medium for point lights), once per
    /// render: the first-scatter source and the deterministic renderer's camera rays read
    /// it. 0 when a channel took it over from an earlier one with the same σ_t, and for the
    /// Monte Carlo renderer without a solve.
    pub light_depth: f64,
    /// Rendering (all views).
    pub render: f64,
    /// Everything.
    pub total: f64,
}

/// Solver statistics.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SolverReport {
    /// Solver name.
    pub solver: String,
    /// Stencil name.
    pub stencil: String,
    /// Iterations.
    pub iterations: usize,
    /// Final relative residual.
    pub relative_residual: f64,
    /// Tolerance.
    pub tolerance: f64,
    /// Whether it converged.
    pub converged: bool,
    /// σ_t threshold used (P_N, CDA).
    pub sigma_t_min: Option<f64>,
    /// Whether it was chosen automatically (vacuum present).
    pub sigma_t_min_auto: bool,
}

/// `report.json` of `pn render`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RenderReport {
    /// Scene name.
    pub scene: String,
    /// Method.
    pub method: String,
    /// P_N order (pn only).
    pub order: Option<usize>,
    /// The renderer: "deterministic" or "montecarlo".
    pub renderer: String,
    /// Camera rays per pixel (deterministic renderer: the k×k pattern; Monte Carlo: spp).
    pub rays_per_pixel: usize,
    /// Step of the deterministic renderer in voxel sides (None for Monte Carlo).
    pub step: Option<f64>,
    /// The step in world units (None for Monte Carlo).
    pub step_length: Option<f64>,
    /// Transmittance cutoff of the deterministic renderer (None for Monte Carlo).
    pub cutoff: Option<f64>,
    /// Deterministic renderer: transmittance to the lights traced at every step (true) or
    /// from the light-depth grid (false; None for Monte Carlo).
    pub exact_transmittance: Option<bool>,
    /// Density filter ("trilinear" or "nearest").
    pub filter: String,
    /// Samples per pixel (Monte Carlo renderer; the scene's value otherwise).
    pub spp: usize,
    /// Seed (Monte Carlo renderer).
    pub seed: u64,
    /// Image size.
    pub width: usize,
    /// Image size.
    pub height: usize,
    /// Density-grid resolution.
    pub density_resolution: [usize; 3],
    /// How the image was integrated.
    pub tracking: String,
    /// Unknowns (None for method none or an empty medium).
    pub unknowns: Option<UnknownStats>,
    /// Solver statistics.
    pub solver: Option<SolverReport>,
    /// Transport sweeps applied to the solution before rendering
    /// (`pn_render::transport_sweep`; 0 without a solve and for method pop).
    pub sweeps: usize,
    /// Method pop: settings, per-light energy bookkeeping per iteration, seconds per stage
    /// (`seconds.sources` is its medium sampling + initialisation, `seconds.solve` its
    /// propagation + resampling).
    pub pop: Option<PopReport>,
    /// Seconds per stage.
    pub seconds: Timings,
    /// Mean pixel value.
    pub mean_radiance: f64,
    /// Root-mean-square of the per-pixel standard errors.
    pub rms_standard_error: f64,
    /// Peak resident memory of the process (bytes).
    pub peak_memory_bytes: Option<u64>,
    /// Worker threads.
    pub threads: usize,
    /// The turntable views (empty for a single view).
    pub views: Vec<ViewReport>,
    /// Warnings (also printed on stderr): an empty medium, a medium out of view.
    pub warnings: Vec<String>,
    /// The `--set SECTION.KEY=VALUE` overrides of the scene file, in order (empty without).
    pub overrides: Vec<String>,
    /// A coloured scene's channels, R, G, B (empty for a grey scene); the fields above then
    /// describe the mean image and sum the channels' times.
    pub channels: Vec<rgb::ChannelReport>,
}

/// One view of a turntable.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ViewReport {
    /// View index k.
    pub index: usize,
    /// Rotation angle 2πk/K about the axis through the target parallel to up (degrees).
    pub angle_deg: f64,
    /// Camera position of the view.
    pub position: [f64; 3],
    /// Seconds to render it.
    pub render_seconds: f64,
    /// Mean pixel value.
    pub mean_radiance: f64,
}

/// A finished render.
pub struct RenderRun {
    /// The image (view 0 of a turntable).
    pub image: Image,
    /// The turntable's images, view 0 first (empty for a single view).
    pub views: Vec<Image>,
    /// The channel images of a coloured scene (`None` for a grey one).
    pub rgb: Option<rgb::RgbImages>,
    /// The multiple-scattering solution on its solve grid (grey scenes with a solve).
    pub solution: Option<MsField>,
    /// The optical depth to the lights (grey scenes that computed it: a solve or the
    /// deterministic renderer).
    pub light_depth: Option<Arc<LightDepth>>,
    /// The staggered solution vector of a P_N or CDA solve (grey scenes), the start guess
    /// for another channel with the same σ_t ([`pipeline::solve_problem_from`]).
    pub staggered: Option<Vec<f64>>,
    /// Its report.
    pub report: RenderReport,
}

/// What a channel's render may take over from channels rendered before it with the same
/// σ_t (both depend on σ_t and the lights' geometry only, or serve as a start).
#[derive(Default)]
pub(crate) struct SharedWork<'a> {
    /// The optical depth to the lights.
    pub light_depth: Option<Arc<LightDepth>>,
    /// Staggered solutions on the same solve grid, to start the iteration from.
    pub guesses: Vec<&'a [f64]>,
}

/// Camera `k` of a `views`-view turntable around `camera`: its position rotated by
/// 2πk/`views` about the axis through the target parallel to up, right-handed about up
/// ([`Camera::orbit`]); view 0 is `camera` itself.
pub fn turntable_camera(camera: &Camera, k: usize, views: usize) -> Camera {
    if k == 0 {
        return camera.clone();
    }
    camera.orbit(2.0 * std::f64::consts::PI * k as f64 / views as f64)
}

/// Most turntable views.
pub const MAX_VIEWS: usize = 3600;

/// Applies the request's overrides to `scene` and checks it again.
pub fn apply_overrides(scene: &mut RenderScene, a: &RenderRequest) -> Result<()> {
    if let Some(m) = a.method {
        scene.solve.method = m;
    }
    if let Some(o) = a.order {
        ensure!(
            matches!(scene.solve.method, RenderMethod::Pn | RenderMethod::Pop),
            "--order applies to --method pn and pop only"
        );
        scene.solve.order = o;
    }
    for (flag, v) in [
        ("--pop-resolution", a.pop_resolution),
        ("--pop-iterations", a.pop_iterations),
    ] {
        ensure!(
            v.is_none() || scene.solve.method == RenderMethod::Pop,
            "{flag} applies to --method pop only"
        );
    }
    for (flag, given) in [
        ("--pop-residuum", a.pop_residuum),
        ("--pop-epsilon-a", a.pop_epsilon_a.is_some()),
        ("--pop-epsilon-l", a.pop_epsilon_l.is_some()),
    ] {
        ensure!(
            !given || scene.solve.method == RenderMethod::Pop,
            "{flag} applies to --method pop only"
        );
    }
    if let Some(r) = a.pop_resolution {
        scene.solve.pop_resolution = r;
    }
    if a.pop_residuum {
        scene.solve.pop_residuum = true;
    }
    if let Some(e) = a.pop_epsilon_a {
        scene.solve.pop_epsilon_a = e;
    }
    if let Some(e) = a.pop_epsilon_l {
        scene.solve.pop_epsilon_l = e;
    }
    if let Some(i) = a.pop_iterations {
        scene.solve.pop_iterations = i;
    }
    if let Some(k) = a.sweeps {
        scene.solve.sweeps = k;
    }
    if let Some(s) = a.spp {
        scene.render.spp = s;
    }
    if let Some(r) = a.renderer {
        scene.render.renderer = r;
    }
    if let Some(r) = a.rays {
        scene.render.rays = r;
    }
    if let Some(s) = a.step {
        scene.render.step = s;
    }
    if a.exact_transmittance {
        scene.render.exact_transmittance = true;
    }
    if let Some(f) = a.filter {
        scene.medium.filter = f;
    }
    if let Some(k) = a.turntable {
        ensure!(
            (1..=MAX_VIEWS).contains(&k),
            "--turntable takes a number of views in 1..={MAX_VIEWS}, got {k}"
        );
    }
    if let Some(r) = &a.solve_res {
        scene.solve.resolution = match r.as_slice() {
            [n] => [*n; 3],
            [x, y, z] => [*x, *y, *z],
            _ => anyhow::bail!("--solve-res takes one number or three (NX,NY,NZ), got {r:?}"),
        };
    }
    scene.solve.validate().context("invalid solve settings")?;
    scene.render.validate().context("invalid render settings")?;
    Ok(())
}

/// The stencil of a method (None for FLD's Gauss–Seidel route and for "none").
fn kernel_for(
    scene: &RenderScene,
    pde: Option<&crate::pde_text::PdeKernel>,
) -> Result<Option<KernelChoice>> {
    if let Some(p) = pde {
        ensure!(
            scene.solve.method == RenderMethod::Cda,
            "internal: a text PDE is solved on the cda route"
        );
        return Ok(Some(p.choice.clone()));
    }
    Ok(match scene.solve.method {
        RenderMethod::Pn => Some(pn_kernel(
            scene.solve.order,
            Dim::Three,
            Staggering::Staggered,
        )?),
        RenderMethod::Cda => Some(cda_kernel(Dim::Three)?),
        RenderMethod::Fld | RenderMethod::Pop | RenderMethod::None => None,
    })
}

/// Unknowns of `kernel` (or interior FLD cells) on the grid of the given resolution.
fn unknowns_on(
    density: &DensityGrid,
    res: [usize; 3],
    margin: usize,
    crop: bool,
    kernel: Option<&KernelChoice>,
) -> Result<(u128, Option<Grid>)> {
    let Some(sg) = solve_grid(density, res, margin, crop)? else {
        return Ok((0, None));
    };
    let n = match kernel {
        Some(k) => memory_estimate::estimate(&sg.grid, k.kernel.as_ref()).unknowns,
        None => sg.grid.res.iter().map(|&r| (r - 2) as u128).product(),
    };
    Ok((n, Some(sg.grid)))
}

/// Solves and renders `scene` (overrides already applied).
pub fn render_scene(scene: &RenderScene, options: &RenderOptions) -> Result<RenderRun> {
    render_views(scene, options, 1)
}

/// Solves `scene` once and renders `views` turntable views of it ([`turntable_camera`];
/// one view: the scene's camera). A coloured scene is solved and rendered per channel
/// ([`rgb`]); its [`RenderRun::image`] is then the mean of the channels.
pub fn render_views(
    scene: &RenderScene,
    options: &RenderOptions,
    views: usize,
) -> Result<RenderRun> {
    if scene.colours.is_some() {
        return rgb::render_views_rgb(scene, options, views);
    }
    render_grey_views(scene, options, views, SharedWork::default())
}

/// [`render_views`] of a grey scene; `shared`: what a scene with the same σ_t and light
/// geometry computed (the optical depth to the lights, reused instead of computed; solutions
/// to start from).
fn render_grey_views(
    scene: &RenderScene,
    options: &RenderOptions,
    views: usize,
    shared: SharedWork<'_>,
) -> Result<RenderRun> {
    let SharedWork {
        light_depth: shared_depth,
        guesses,
    } = shared;
    ensure!(
        scene.colours.is_none(),
        "internal: a coloured scene must be rendered channel by channel"
    );
    ensure!(
        (1..=MAX_VIEWS).contains(&views),
        "the number of views must lie in 1..={MAX_VIEWS}, got {views}"
    );
    let RenderOptions {
        threads,
        max_memory,
        progress,
        ref tuning,
        ref pde,
        ref observer,
    } = *options;
    let pde = pde.as_deref();
    let t_all = Instant::now();
    let t0 = Instant::now();
    let density = scene.density_grid()?;
    let seconds_density = t0.elapsed().as_secs_f64();
    let s = &scene.solve;
    let mut timings = Timings {
        density: seconds_density,
        ..Timings::default()
    };
    let mut unknowns = None;
    let mut solver = None;
    let mut ms = None;
    let mut light_depth: Option<Arc<LightDepth>> = None;
    let mut staggered = None;
    let mut pop = None;
    let mut sweeps_done = 0;
    if s.method == RenderMethod::Pop {
        // No linear system: POP's moments of the collided radiance go onto the solve grid.
        if let Some(sg) = solve_grid(&density, s.resolution, s.padding(), true)? {
            let settings = PopSettings {
                resolution: s.pop_resolution,
                iterations: s.pop_iterations,
                lmax: s.order,
                residuum: s.pop_residuum.then_some(ResiduumSettings {
                    epsilon_a: s.pop_epsilon_a,
                    epsilon_l: s.pop_epsilon_l,
                }),
            };
            let run = pn_runtime::threads::with_threads(threads, || {
                pop_field(scene, &density, &sg.grid, &settings)
            })??;
            let p = &run.report.seconds;
            timings.sources = p.medium + p.initialization;
            timings.solve = p.propagation + p.resampling;
            ms = Some(
                MsField::new(sg.grid, run.moments, scene.phase)?
                    .with_lookup(scene.render.ms_lookup),
            );
            pop = Some(run.report);
        }
    } else if s.method != RenderMethod::None {
        let kernel = kernel_for(scene, pde)?;
        let (solved, grid) =
            unknowns_on(&density, s.resolution, s.padding(), true, kernel.as_ref())?;
        if let Some(grid) = grid {
            let (uncropped, _) =
                unknowns_on(&density, s.resolution, s.padding(), false, kernel.as_ref())?;
            let (fine, _) = unknowns_on(&density, density.res, s.padding(), true, kernel.as_ref())?;
            let (fine_full, _) =
                unknowns_on(&density, density.res, s.padding(), false, kernel.as_ref())?;
            unknowns = Some(UnknownStats {
                solved,
                uncropped,
                cropped_at_density_resolution: fine,
                uncropped_at_density_resolution: fine_full,
                solve_grid_res: grid.res,
                solve_grid_min: grid.min,
                solve_grid_max: grid.max,
            });
            if let Some(k) = &kernel {
                memory_estimate::check_limit(
                    &memory_estimate::estimate(&grid, k.kernel.as_ref()),
                    max_memory.unwrap_or_else(memory_estimate::default_limit_bytes),
                )?;
            }
            // The first-scatter source's bands: P_N reads Q_l^m up to l = N, a text PDE up
            // to the highest band it references (filtered P_N: N; SP_N and CDA: 0).
            let max_band = match pde {
                Some(p) => p.source_band,
                None if s.method == RenderMethod::Pn => s.order as u32,
                None => 0,
            };
            let fs = pn_runtime::threads::with_threads(threads, || {
                first_scatter_problem_with_depth(
                    scene,
                    &density,
                    &grid,
                    max_band,
                    shared_depth.clone(),
                )
            })??;
            timings.light_depth = fs.seconds_light_depth;
            timings.sources = fs.seconds_sources;
            let t1 = Instant::now();
            let (moments, u, report) = pn_runtime::threads::with_threads(threads, || {
                solve_ms(
                    scene,
                    &fs.problem,
                    kernel.as_ref(),
                    progress,
                    observer.as_ref(),
                    tuning,
                    &guesses,
                )
            })??;
            staggered = u;
            let mut moments = moments;
            if let Some(p) = pde {
                // Auxiliary unknowns (SP_3's φ_2) are not radiance moments: the renderer
                // must not read them as spherical-harmonic coefficients.
                p.zero_auxiliary(&mut moments);
            }
            timings.solve = t1.elapsed().as_secs_f64();
            if s.sweeps > 0 {
                let t2 = Instant::now();
                moments = pn_runtime::threads::with_threads(threads, || {
                    transport_sweeps(
                        &fs.problem,
                        &moments,
                        SweepSettings {
                            sweeps: s.sweeps,
                            n_mu: s.sweep_quadrature,
                        },
                    )
                })??;
                timings.sweeps = t2.elapsed().as_secs_f64();
                sweeps_done = s.sweeps;
            }
            solver = Some(SolverReport {
                sigma_t_min: (s.method != RenderMethod::Fld)
                    .then_some(fs.problem.sigma_t_min)
                    .flatten(),
                sigma_t_min_auto: fs.auto_sigma_t_min && s.method != RenderMethod::Fld,
                ..report
            });
            ms =
                Some(MsField::new(grid, moments, scene.phase)?.with_lookup(scene.render.ms_lookup));
            light_depth = Some(fs.depth);
        }
    }
    let mut warnings: Vec<String> = pop.iter().flat_map(|p| p.warnings.clone()).collect();
    let support = density
        .support()
        .filter(|_| scene.medium.sigma_t_scale > 0.0);
    if support.is_none() {
        warnings.push(
            "the medium is empty (no density > 0, or sigma_t_scale = 0): the image is black"
                .to_string(),
        );
    }
    let r = &scene.render;
    let deterministic = r.renderer == RendererKind::Deterministic;
    // The solve's optical depth to the lights (or an earlier channel's) serves the camera
    // rays too; a render without a solve computes it here.
    if deterministic {
        light_depth = light_depth.or(shared_depth);
        if light_depth.is_none() {
            let t_ld = Instant::now();
            let ext = Extinction {
                grid: &density,
                scale: scene.medium.sigma_t_scale,
            };
            light_depth = Some(Arc::new(pn_runtime::threads::with_threads(
                threads,
                || LightDepth::compute(&ext, &scene.lights),
            )?));
            timings.light_depth = t_ld.elapsed().as_secs_f64();
        }
    }
    let settings = MarchSettings {
        rays: r.rays,
        step: r.step,
        cutoff: r.cutoff,
        exact_transmittance: r.exact_transmittance,
    };
    let marcher = light_depth
        .as_deref()
        .filter(|_| deterministic)
        .map(|ld| Marcher::new(scene, &density, ms.as_ref(), ld, settings));
    let mut images = Vec::with_capacity(views);
    let mut view_reports = Vec::new();
    for k in 0..views {
        let camera = turntable_camera(&scene.camera, k, views);
        if let Some((lo, hi)) = support {
            if !camera.sees_box(lo, hi) {
                let which = if views > 1 {
                    format!("view {k}: ")
                } else {
                    String::new()
                };
                warnings.push(format!(
                    "{which}the medium (box {lo:?} to {hi:?}) is outside the camera's view: \
                     the image is black"
                ));
            }
        }
        let t2 = Instant::now();
        let image = match &marcher {
            Some(m) => pn_runtime::threads::with_threads(threads, || m.render(&camera, progress))?,
            None => {
                let view_scene;
                let sc = if k == 0 {
                    scene
                } else {
                    view_scene = RenderScene {
                        camera: camera.clone(),
                        ..scene.clone()
                    };
                    &view_scene
                };
                let renderer = Renderer {
                    scene: sc,
                    density: &density,
                    ms: ms.as_ref(),
                };
                pn_runtime::threads::with_threads(threads, || {
                    renderer.render(r.spp, r.seed, progress)
                })?
            }
        };
        let secs = t2.elapsed().as_secs_f64();
        timings.render += secs;
        if views > 1 {
            view_reports.push(ViewReport {
                index: k,
                angle_deg: 360.0 * k as f64 / views as f64,
                position: camera.position,
                render_seconds: secs,
                mean_radiance: mean(&image.data),
            });
        }
        images.push(image);
    }
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    timings.total = t_all.elapsed().as_secs_f64();
    let image = images[0].clone();
    let hmin = density.h().iter().fold(f64::INFINITY, |m, v| m.min(*v));
    let report = RenderReport {
        scene: scene.name.clone(),
        method: match pde {
            Some(p) => format!("pde:{}", p.name),
            None => s.method.name().into(),
        },
        order: matches!(s.method, RenderMethod::Pn | RenderMethod::Pop).then_some(s.order),
        renderer: r.renderer.name().into(),
        rays_per_pixel: if deterministic { r.rays } else { r.spp },
        step: deterministic.then_some(r.step),
        step_length: deterministic.then_some(r.step * hmin),
        cutoff: deterministic.then_some(r.cutoff),
        exact_transmittance: deterministic.then_some(r.exact_transmittance),
        filter: density.filter.name().into(),
        spp: r.spp,
        seed: r.seed,
        width: image.width,
        height: image.height,
        density_resolution: density.res,
        tracking: if deterministic {
            if r.exact_transmittance {
                "ray marching, exponential midpoint rule on the filter's lattice pieces; \
                 exact transmittance to the lights (traversal at every step)"
            } else {
                "ray marching, exponential midpoint rule on the filter's lattice pieces; \
                 transmittance to the lights from the optical-depth grid at the voxel \
                 centres"
            }
        } else {
            "delta tracking with the global majorant; next-event estimation with exact \
             voxel-traversal transmittance"
        }
        .into(),
        unknowns,
        solver,
        sweeps: sweeps_done,
        pop,
        seconds: timings,
        mean_radiance: mean(&image.data),
        rms_standard_error: rms(&image.std_err),
        peak_memory_bytes: pn_runtime::memory::peak_memory_bytes(),
        threads: pn_runtime::threads::effective_threads(threads),
        views: view_reports,
        warnings,
        overrides: Vec::new(),
        channels: Vec::new(),
    };
    Ok(RenderRun {
        image,
        views: if views > 1 { images } else { Vec::new() },
        rgb: None,
        solution: ms,
        light_depth,
        staggered,
        report,
    })
}

fn mean(data: &[f32]) -> f64 {
    data.iter().map(|v| *v as f64).sum::<f64>() / data.len().max(1) as f64
}

/// Root mean square of the values.
fn rms(data: &[f32]) -> f64 {
    (data.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / data.len().max(1) as f64).sqrt()
}

/// "solver NAME: K iterations, relative residual R" of the summary lines.
fn solver_line(s: &SolverReport) -> String {
    format!(
        "solver {}: {} iterations, relative residual {:.3e}{}",
        s.solver,
        s.iterations,
        s.relative_residual,
        if s.converged { "" } else { " (NOT converged)" }
    )
}

/// The solver tuning of render solves: `tuning` with the multigrid's finest level
/// multiplicative (Chebyshev smoothing around the coarse correction) unless a fine cycle was
/// asked for (`PN_MG_ADDITIVE`). The solver's own default joins the finest level additively
/// where the operator is symmetric, which is best on homogeneous media (80³ P_1 point source,
/// docs/solvers.md); render media are clouds in near-vacuum with the hull absorber around
/// them, where the additive form needs 3–4× the iterations. Measured 2026-12-04
/// (`PN_SOLVER_PROFILE=1 pn render <scene> --order N --solve-res R`, CG iterations and
/// iterate seconds, additive → multiplicative): P_3 @ 16³ puff 224 → 66 (0.34 → 0.21 s),
/// nebula 209 → 65 (0.32 → 0.20 s), cumulus 254 → 74 (0.39 → 0.23 s); P_5 @ 32³ puff 351 →
/// 102 (5.3 → 4.2 s), nebula 320 → 98 (3.9 → 3.3 s), cumulus 400 → 115 (5.8 → 4.4 s), cloud
/// 348 → 102 (4.9 → 4.4 s).
fn render_tuning(tuning: &SolverTuning) -> SolverTuning {
    let mut mg = tuning.multigrid.clone().unwrap_or_default();
    if mg.fine_cycle == FineCycle::AdditiveIfSymmetric {
        mg.fine_cycle = FineCycle::Multiplicative;
    }
    SolverTuning {
        multigrid: Some(mg),
        ..tuning.clone()
    }
}

/// Solves the multiple scattering: P_N / CDA through the stencil and parity-MG, FLD through
/// `[solve] fld_solver` (Picard steps on multigrid-CG, or Gauss–Seidel; Levermore–Pomraning limiter). Returns the cell-centred moments.
fn solve_ms(
    scene: &RenderScene,
    problem: &pn_runtime::problem::Problem,
    kernel: Option<&KernelChoice>,
    progress: bool,
    observer: Option<&pn_runtime::solver::IterationObserver>,
    tuning: &SolverTuning,
    guesses: &[&[f64]],
) -> Result<(CellMoments, Option<Vec<f64>>, SolverReport)> {
    let tol = scene.solve.tolerance;
    if scene.solve.method == RenderMethod::Fld {
        let g = &problem.grid;
        ensure!(
            (0..3).all(|d| (g.h(d) - g.h(0)).abs() <= 1e-9 * g.h(0)),
            "--method fld needs cubic solve cells, got h = ({:.4}, {:.4}, {:.4}): make \
             [solve] resolution proportional to the medium box extents",
            g.h(0),
            g.h(1),
            g.h(2)
        );
        let fp = fld_problem(problem)?;
        let params = FldParams {
            tol,
            ..FldParams::for_grid(Limiter::LevermorePomraning, &fp.grid)
        };
        params.validate(&fp).context("FLD settings")?;
        let settings = FldSettings {
            params,
            route: match scene.solve.fld_solver {
                FldSolver::Picard => Route::Picard,
                FldSolver::Gs => Route::GaussSeidel,
            },
            linear_solver: SolverKind::ParityCg,
            tuning: tuning.clone(),
        };
        let dk = diffusion_kernel(Dim::Three)?;
        let run = solve_fld_route(&fp, &settings, &dk, None)?;
        let s = &run.solution;
        if !s.converged {
            eprintln!(
                "warning: FLD stopped at relative residual {:.3e} after {} iterations",
                s.final_residual(),
                s.iterations
            );
        }
        let moments = CellMoments {
            res: problem.grid.res,
            per_cell: 1,
            data: s.phi.iter().map(|v| v / SQRT_4PI).collect(),
        };
        return Ok((
            moments,
            None,
            SolverReport {
                solver: match &run.linear_solver {
                    Some(linear) => format!("fld-picard({linear}) (Levermore–Pomraning)"),
                    None => "fld-gs (Levermore–Pomraning)".into(),
                },
                stencil: "fld-7point".into(),
                iterations: s.iterations,
                relative_residual: s.final_residual(),
                tolerance: tol,
                converged: s.converged,
                sigma_t_min: None,
                sigma_t_min_auto: false,
            },
        ));
    }
    let kernel = kernel.context("internal: no stencil for the method")?;
    let opts = SolverOptions {
        tol,
        observer: crate::progress::terminal_observer(progress, observer.cloned()),
        tuning: render_tuning(tuning),
        ..Default::default()
    };
    // Always multigrid: parity-cg's automatic choice for small systems, ILU(0)-preconditioned
    // CG, stagnates on render grids where the hull absorber jumps to σ_t·h = 3 within one
    // cell of a near-vacuum (12³ sphere: residual 7.6e-2 after 100 000 iterations, where
    // multigrid converges in 195; docs/vacuum.md).
    let sol = solve_problem_from(
        problem,
        kernel.kernel.as_ref(),
        SolverKind::ParityMg,
        &opts,
        guesses,
    )?;
    crate::progress::print_notes(&sol.stats.notes);
    if !sol.stats.converged() {
        eprintln!(
            "warning: the solver stopped ({:?}) at relative residual {:.3e} after {} iterations",
            sol.stats.status, sol.stats.relative_residual, sol.stats.iterations
        );
    }
    let report = SolverReport {
        solver: sol.stats.solver.clone(),
        stencil: kernel.kernel.name().to_string(),
        iterations: sol.stats.iterations,
        relative_residual: sol.stats.relative_residual,
        tolerance: tol,
        converged: sol.stats.converged(),
        sigma_t_min: None,
        sigma_t_min_auto: false,
    };
    Ok((sol.moments, Some(sol.u), report))
}

/// Writes `image.exr`, `image.png` and `report.json` into `dir` (a turntable:
/// `view_000.exr`, `view_000.png`, … instead of `image.*`).
pub fn write_run(dir: &Path, run: &RenderRun) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    if let Some(rgb) = &run.rgb {
        rgb.write(dir)?;
    } else if run.views.is_empty() {
        let im = &run.image;
        write_exr_gray(&dir.join("image.exr"), im.width, im.height, &im.data)?;
        write_png_tonemapped(&dir.join("image.png"), im.width, im.height, &im.data, None)?;
    } else {
        // One exposure for all views (from view 0), so that the PNGs compare.
        let expo = pn_formats::image_io::exposure(&run.views[0].data);
        for (k, im) in run.views.iter().enumerate() {
            write_exr_gray(
                &dir.join(format!("view_{k:03}.exr")),
                im.width,
                im.height,
                &im.data,
            )?;
            write_png_tonemapped(
                &dir.join(format!("view_{k:03}.png")),
                im.width,
                im.height,
                &im.data,
                Some(expo),
            )?;
        }
    }
    let path = dir.join("report.json");
    std::fs::write(&path, serde_json::to_string_pretty(&run.report)? + "\n")
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Runs `pn render`: renders, writes `image.exr`, `image.png` (or the turntable's
/// `view_NNN.*`) and `report.json` and prints a summary to `stdout`.
pub fn run(a: &RenderRequest, stdout: &mut dyn Write) -> Result<()> {
    let mut scene = RenderScene::load_with_overrides(&a.scene, &a.set)?;
    apply_overrides(&mut scene, a)?;
    let mut options = a.options.clone();
    if let Some(path) = &a.pde {
        ensure!(
            a.method.is_none() && a.order.is_none(),
            "--pde replaces --method and --order (the PDE file says what is solved)"
        );
        scene.solve.method = RenderMethod::Cda;
        options.pde = Some(std::sync::Arc::new(crate::pde_text::PdeKernel::load(
            path,
            &a.pde_params,
        )?));
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("render-{}", scene.name)));
    ensure!(
        !a.save_moments || (scene.colours.is_none() && scene.solve.method != RenderMethod::None),
        "--save-moments needs a grey scene with a solve (method pn, cda, fld or pop); for a \
         coloured scene, render each channel's scene"
    );
    let mut run = render_views(&scene, &options, a.turntable.unwrap_or(1))?;
    run.report.overrides = a.set.iter().map(|o| o.text.clone()).collect();
    let save = match &run.solution {
        Some(ms) if a.save_moments => Some(ms),
        None if a.save_moments => bail!("--save-moments: no solution to write (an empty medium?)"),
        _ => None,
    };
    write_run(&out, &run)?;
    if let Some(ms) = save {
        let m = &ms.moments;
        let path = out.join("moments.npy");
        pn_formats::npy::write_npy(&path, &[m.res[0], m.res[1], m.res[2], m.per_cell], &m.data)?;
    }
    let r = &run.report;
    let what = match (r.order, &r.pop) {
        (_, Some(p)) => format!(
            "POP ({}³ grid, {} iterations, l ≤ {})",
            p.settings.resolution, p.settings.iterations, p.settings.lmax
        ),
        (Some(n), None) => format!("P_{n}"),
        (None, None) => r.method.to_uppercase(),
    };
    let how = match (r.step, r.cutoff) {
        (Some(step), Some(_)) => format!(
            "deterministic, {} rays/px, step {step} voxel",
            r.rays_per_pixel
        ),
        _ => format!("Monte Carlo, {} spp", r.spp),
    };
    let views = if r.views.is_empty() {
        String::new()
    } else {
        format!(" ({} views)", r.views.len())
    };
    writeln!(
        stdout,
        "{} {what}: {}×{} px, {how}, {} filter; light depth {:.3} s, sources {:.3} s, solve \
         {:.3} s, {}render {:.3} s{views} -> {}",
        r.scene,
        r.width,
        r.height,
        r.filter,
        r.seconds.light_depth,
        r.seconds.sources,
        r.seconds.solve,
        if r.sweeps > 0 {
            format!("{} sweeps {:.3} s, ", r.sweeps, r.seconds.sweeps)
        } else {
            String::new()
        },
        r.seconds.render,
        out.display()
    )?;
    if let Some(s) = &r.solver {
        writeln!(stdout, "{}", solver_line(s))?;
    }
    for c in &r.channels {
        let how = match (&c.copied_from, &c.solver) {
            (Some(from), _) => match c.copy_scale {
                Some(k) if k != 1.0 => format!("{from} scaled by {k} (same medium, lights ×{k})"),
                _ => format!("copied from {from} (same values)"),
            },
            (None, Some(s)) => solver_line(s),
            (None, None) => "no solve".into(),
        };
        writeln!(
            stdout,
            "channel {}: sigma_t_scale {}, mean radiance {:.4e}; {how}",
            c.channel, c.sigma_t_scale, c.mean_radiance
        )?;
    }
    if a.stats {
        match &r.unknowns {
            Some(u) => writeln!(
                stdout,
                "unknowns: {} solved (cropped, solve grid {:?}); {} uncropped; at the density \
                 resolution {} cropped, {} uncropped",
                u.solved,
                u.solve_grid_res,
                u.uncropped,
                u.cropped_at_density_resolution,
                u.uncropped_at_density_resolution
            )?,
            None => writeln!(
                stdout,
                "unknowns: none (single scattering only or an empty medium)"
            )?,
        }
    }
    Ok(())
}
