//! `pn render <scene.toml | builtin>`: solves the multiple scattering of a render scene on
//! its (cropped, possibly coarser) solve grid and renders the image (docs/rendering.md). Writes `image.exr` (linear), `image.png` (tone-mapped) and
//! `report.json` (times, unknowns with and without cropping and at the density resolution,
//! solver statistics, peak memory).
//!
//! The pieces live in `pn_runtime::render`; this module only picks the stencil (P_N or
//! CDA through `pn_kernels`, FLD through [`super::fld_method`]) and runs the chain.

use crate::fld_setup::{fld_problem, solve_fld_route, FldSettings, SQRT_4PI};
use crate::scene_setup::Route;
use anyhow::{ensure, Context, Result};
use pn_kernels::{cda_kernel, diffusion_kernel, pn_kernel, Dim, KernelChoice, Staggering};
use pn_runtime::fld::{FldParams, Limiter};
use pn_runtime::memory_estimate;
use pn_runtime::pipeline::solve_problem;
use pn_runtime::problem::Grid;
use pn_runtime::render::first_scatter::first_scatter_problem;
use pn_runtime::render::image_io::{write_exr_gray, write_png_tonemapped};
use pn_runtime::render::renderer::{Image, MsField, Renderer};
use pn_runtime::render::scene::RenderMethod;
use pn_runtime::render::solve_setup::solve_grid;
use pn_runtime::render::{DensityGrid, RenderScene};
use pn_runtime::solver::{SolverKind, SolverOptions, SolverTuning};
use pn_runtime::unstagger::CellMoments;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The options of `pn render`: the scene and the overrides of its settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderRequest {
    /// A scene file (`.toml`) or a built-in scene: cloud, nebula, sphere, lowalbedo.
    pub scene: String,
    /// Multiple scattering: pn, cda, fld, or none (default: the scene's).
    pub method: Option<RenderMethod>,
    /// P_N order (method pn; default: the scene's).
    pub order: Option<usize>,
    /// Samples per pixel (default: the scene's).
    pub spp: Option<usize>,
    /// Solve-grid cells across the medium box: one number for all axes or three.
    pub solve_res: Option<Vec<usize>>,
    /// Output directory (default `out/render-<scene>`).
    pub out: Option<PathBuf>,
    /// Print the unknowns with and without cropping and at the density resolution.
    pub stats: bool,
    /// Threads, memory limit, progress bars and solver tuning.
    pub options: RenderOptions,
}

impl Default for RenderRequest {
    /// The `nebula` scene with its own settings.
    fn default() -> Self {
        Self {
            scene: "nebula".into(),
            method: None,
            order: None,
            spp: None,
            solve_res: None,
            out: None,
            stats: false,
            options: RenderOptions::default(),
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
}

impl Default for RenderOptions {
    /// All cores, the default memory limit, progress bars, tuned solver defaults.
    fn default() -> Self {
        Self {
            threads: None,
            max_memory: None,
            progress: true,
            tuning: SolverTuning::default(),
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
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Timings {
    /// Building the density grid.
    pub density: f64,
    /// Deep shadow maps at the solve-cell centres.
    pub shadow_maps: f64,
    /// Resampling σ_t, σ_s and projecting the first-scatter source.
    pub sources: f64,
    /// Assembly + linear (or FLD) solve.
    pub solve: f64,
    /// Rendering.
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
    /// Samples per pixel.
    pub spp: usize,
    /// Seed.
    pub seed: u64,
    /// Image size.
    pub width: usize,
    /// Image size.
    pub height: usize,
    /// Density-grid resolution.
    pub density_resolution: [usize; 3],
    /// Free-flight sampling.
    pub tracking: String,
    /// Unknowns (None for method none or an empty medium).
    pub unknowns: Option<UnknownStats>,
    /// Solver statistics.
    pub solver: Option<SolverReport>,
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
}

/// A finished render.
pub struct RenderRun {
    /// The image.
    pub image: Image,
    /// Its report.
    pub report: RenderReport,
}

/// Applies the request's overrides to `scene` and checks it again.
pub fn apply_overrides(scene: &mut RenderScene, a: &RenderRequest) -> Result<()> {
    if let Some(m) = a.method {
        scene.solve.method = m;
    }
    if let Some(o) = a.order {
        ensure!(
            scene.solve.method == RenderMethod::Pn,
            "--order applies to --method pn only"
        );
        scene.solve.order = o;
    }
    if let Some(s) = a.spp {
        scene.render.spp = s;
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
fn kernel_for(scene: &RenderScene) -> Result<Option<KernelChoice>> {
    Ok(match scene.solve.method {
        RenderMethod::Pn => Some(pn_kernel(
            scene.solve.order,
            Dim::Three,
            Staggering::Staggered,
        )?),
        RenderMethod::Cda => Some(cda_kernel(Dim::Three)?),
        RenderMethod::Fld | RenderMethod::None => None,
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
    let RenderOptions {
        threads,
        max_memory,
        progress,
        ref tuning,
    } = *options;
    let t_all = Instant::now();
    let t0 = Instant::now();
    let density = scene.density_grid()?;
    let seconds_density = t0.elapsed().as_secs_f64();
    let s = &scene.solve;
    let mut timings = Timings {
        density: seconds_density,
        shadow_maps: 0.0,
        sources: 0.0,
        solve: 0.0,
        render: 0.0,
        total: 0.0,
    };
    let mut unknowns = None;
    let mut solver = None;
    let mut ms = None;
    if s.method != RenderMethod::None {
        let kernel = kernel_for(scene)?;
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
            let max_band = if s.method == RenderMethod::Pn {
                s.order as u32
            } else {
                0
            };
            let fs = pn_runtime::threads::with_threads(threads, || {
                first_scatter_problem(scene, &density, &grid, max_band)
            })??;
            timings.shadow_maps = fs.seconds_shadow_maps;
            timings.sources = fs.seconds_sources;
            let t1 = Instant::now();
            let (moments, report) = pn_runtime::threads::with_threads(threads, || {
                solve_ms(scene, &fs.problem, kernel.as_ref(), progress, tuning)
            })??;
            timings.solve = t1.elapsed().as_secs_f64();
            solver = Some(SolverReport {
                sigma_t_min: (s.method != RenderMethod::Fld)
                    .then_some(fs.problem.sigma_t_min)
                    .flatten(),
                sigma_t_min_auto: fs.auto_sigma_t_min && s.method != RenderMethod::Fld,
                ..report
            });
            ms = Some(MsField::new(grid, moments, scene.phase)?);
        }
    }
    let t2 = Instant::now();
    let renderer = Renderer {
        scene,
        density: &density,
        ms: ms.as_ref(),
    };
    let image = pn_runtime::threads::with_threads(threads, || {
        renderer.render(scene.render.spp, scene.render.seed, progress)
    })?;
    timings.render = t2.elapsed().as_secs_f64();
    timings.total = t_all.elapsed().as_secs_f64();
    let n = image.data.len() as f64;
    let report = RenderReport {
        scene: scene.name.clone(),
        method: s.method.name().into(),
        order: (s.method == RenderMethod::Pn).then_some(s.order),
        spp: scene.render.spp,
        seed: scene.render.seed,
        width: image.width,
        height: image.height,
        density_resolution: density.res,
        tracking: "delta tracking with the global majorant; next-event estimation with exact \
                   voxel-traversal transmittance"
            .into(),
        unknowns,
        solver,
        seconds: timings,
        mean_radiance: image.data.iter().map(|v| *v as f64).sum::<f64>() / n,
        rms_standard_error: (image
            .std_err
            .iter()
            .map(|v| (*v as f64).powi(2))
            .sum::<f64>()
            / n)
            .sqrt(),
        peak_memory_bytes: pn_runtime::memory::peak_memory_bytes(),
        threads: pn_runtime::threads::effective_threads(threads),
    };
    Ok(RenderRun { image, report })
}

/// Solves the multiple scattering: P_N / CDA through the stencil and parity-CG, FLD through
/// its Gauss–Seidel solver (Levermore–Pomraning limiter). Returns the cell-centred moments.
fn solve_ms(
    scene: &RenderScene,
    problem: &pn_runtime::problem::Problem,
    kernel: Option<&KernelChoice>,
    progress: bool,
    tuning: &SolverTuning,
) -> Result<(CellMoments, SolverReport)> {
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
            route: Route::GaussSeidel,
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
            SolverReport {
                solver: "fld-gs (Levermore–Pomraning)".into(),
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
        progress,
        tuning: tuning.clone(),
        ..Default::default()
    };
    let sol = solve_problem(problem, kernel.kernel.as_ref(), SolverKind::ParityCg, &opts)?;
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
    Ok((sol.moments, report))
}

/// Writes `image.exr`, `image.png` and `report.json` into `dir`.
pub fn write_run(dir: &Path, run: &RenderRun) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let im = &run.image;
    write_exr_gray(&dir.join("image.exr"), im.width, im.height, &im.data)?;
    write_png_tonemapped(&dir.join("image.png"), im.width, im.height, &im.data, None)?;
    let path = dir.join("report.json");
    std::fs::write(&path, serde_json::to_string_pretty(&run.report)? + "\n")
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Runs `pn render`: renders, writes `image.exr`, `image.png` and `report.json` and prints
/// a summary to `stdout`.
pub fn run(a: &RenderRequest, stdout: &mut dyn Write) -> Result<()> {
    let mut scene = RenderScene::load(&a.scene)?;
    apply_overrides(&mut scene, a)?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("render-{}", scene.name)));
    let run = render_scene(&scene, &a.options)?;
    write_run(&out, &run)?;
    let r = &run.report;
    let what = match r.order {
        Some(n) => format!("P_{n}"),
        None => r.method.to_uppercase(),
    };
    writeln!(
        stdout,
        "{} {what}: {}×{} px, {} spp; shadow maps {:.3} s, sources {:.3} s, solve {:.3} s, \
         render {:.3} s -> {}",
        r.scene,
        r.width,
        r.height,
        r.spp,
        r.seconds.shadow_maps,
        r.seconds.sources,
        r.seconds.solve,
        r.seconds.render,
        out.display()
    )?;
    if let Some(s) = &r.solver {
        writeln!(
            stdout,
            "solver {}: {} iterations, relative residual {:.3e}{}",
            s.solver,
            s.iterations,
            s.relative_residual,
            if s.converged { "" } else { " (NOT converged)" }
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
