//! `pn render <scene.toml | builtin>`: solves the multiple scattering of a render scene on
//! its (cropped, possibly coarser) solve grid and renders the image (docs/rendering.md). Writes `image.exr` (linear), `image.png` (tone-mapped) and
//! `report.json` (times, unknowns with and without cropping and at the density resolution,
//! solver statistics, peak memory).
//!
//! The command only reads the request, applies its overrides to the scene, calls
//! [`pn_render::render_views`] (the whole chain: methods, first scatter, solve, sweeps,
//! renderers), draws the progress bars and prints the run's notes, and writes the images
//! and the one report through `pn_formats`.

use anyhow::{bail, ensure, Context, Result};
use pn_formats::{
    exposure, write_exr_gray, write_exr_rgb, write_png_tonemapped, write_png_tonemapped_rgb,
};
use pn_render::pde_kernel::PdeKernel;
use pn_render::scene::{RenderMethod, RendererKind};
use pn_render::{DensityFilter, RenderScene, RgbImages, SceneOverride};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use pn_render::{
    turntable_camera, ChannelReport, RenderOptions, RenderReport, RenderRun, SolverReport, Timings,
    UnknownStats, ViewReport, MAX_VIEWS,
};

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
    /// Render K views of one solve around the target ([`pn_render::turntable_camera`]).
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
    /// `--distributed`: the linear solves split over MPI processes (docs/distributed.md);
    /// process 0 renders and writes.
    pub distributed: Option<crate::scene_setup::DistributedRequest>,
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
            distributed: None,
        }
    }
}

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

/// [`pn_render::render_views`] with the command's terminal: a progress bar over the image
/// rows when `options.progress` (drawn only when stderr is a terminal; unless the options
/// carry their own row callback), and the run's notes printed on stderr.
pub fn render_views(
    scene: &RenderScene,
    options: &RenderOptions,
    views: usize,
) -> Result<RenderRun> {
    let mut options = options.clone();
    if options.progress && options.rows.is_none() {
        options.rows = Some(crate::progress::row_progress_bar());
    }
    // The solver's bar (iterations and residual), as the solver drew it before it was a
    // library that never draws.
    options.observer =
        crate::progress::terminal_observer(options.progress, options.observer.take());
    let run = pn_render::render_views(scene, &options, views)?;
    crate::progress::print_notes(&run.notes);
    Ok(run)
}

/// [`render_views`] of the scene's own camera.
pub fn render_scene(scene: &RenderScene, options: &RenderOptions) -> Result<RenderRun> {
    render_views(scene, options, 1)
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

/// Writes `image.exr`, `image.png` and `report.json` into `dir` (a turntable:
/// `view_000.exr`, `view_000.png`, … instead of `image.*`).
/// The files appear together once all are written (a failure leaves none).
pub fn write_run(dir: &Path, run: &RenderRun) -> Result<()> {
    let stage = pn_formats::files::StagedDir::new(dir)?;
    write_run_files(stage.path(), run)?;
    stage.commit()
}

/// [`write_run`]'s files, written into the folder `dir`.
fn write_run_files(dir: &Path, run: &RenderRun) -> Result<()> {
    if let Some(rgb) = &run.rgb {
        write_rgb(dir, rgb)?;
    } else if run.views.is_empty() {
        let im = &run.image;
        write_exr_gray(&dir.join("image.exr"), im.width, im.height, &im.data)?;
        write_png_tonemapped(&dir.join("image.png"), im.width, im.height, &im.data, None)?;
    } else {
        // One exposure for all views (from view 0), so that the PNGs compare.
        let expo = exposure(&run.views[0].data);
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
        options.pde = Some(Arc::new(PdeKernel::load(path, &a.pde_params)?));
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
    let mut run = match &a.distributed {
        None => render_views(&scene, &options, a.turntable.unwrap_or(1))?,
        Some(d) => {
            // Every process runs the render's solves together (they are collective); the
            // others render 1×1-pixel images, only process 0's are of use.
            let mut done = None;
            let mut one_pixel = scene.clone();
            (one_pixel.camera.width, one_pixel.camera.height) = (1, 1);
            crate::solve_distributed::run_render(d, &mut |solver, root| {
                let mut o = options.clone();
                o.linear_solver = Some(solver);
                o.progress &= root;
                let here = if root { &scene } else { &one_pixel };
                let run = render_views(here, &o, a.turntable.unwrap_or(1))?;
                if root {
                    done = Some(run);
                }
                Ok(())
            })?;
            match done {
                Some(run) => run,
                None => return Ok(()),
            }
        }
    };
    run.report.overrides = a.set.iter().map(|o| o.text.clone()).collect();
    let save = match &run.solution {
        Some(ms) if a.save_moments => Some(ms),
        None if a.save_moments => bail!("--save-moments: no solution to write (an empty medium?)"),
        _ => None,
    };
    // Every file at once, only when all are written (issue 53).
    let stage = pn_formats::files::StagedDir::new(&out)?;
    write_run_files(stage.path(), &run)?;
    if let Some(ms) = save {
        let m = &ms.moments;
        let path = stage.path().join("moments.npy");
        pn_formats::write_npy(&path, &[m.res[0], m.res[1], m.res[2], m.per_cell], &m.data)?;
    }
    stage.commit()?;
    write_summary(stdout, &run.report, &out, a.stats)
}

/// The summary lines of `pn render` on `stdout`: what was rendered and how long each stage
/// took, the solver (or each channel's), and with `stats` the unknowns.
fn write_summary(stdout: &mut dyn Write, r: &RenderReport, out: &Path, stats: bool) -> Result<()> {
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
    if stats {
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

/// Writes `image.exr` (linear RGB) and `image.png` (tone-mapped RGB) into `dir`, or for a
/// turntable `view_NNN.exr` and `view_NNN.png` with one exposure (from view 0).
fn write_rgb(dir: &Path, rgb: &RgbImages) -> Result<()> {
    let (w, h) = (rgb.image[0].width, rgb.image[0].height);
    if rgb.views.is_empty() {
        write_exr_rgb(&dir.join("image.exr"), w, h, rgb.planes(None))?;
        return write_png_tonemapped_rgb(&dir.join("image.png"), w, h, rgb.planes(None), None);
    }
    let expo = exposure(&rgb.planes(Some(0)).concat());
    for k in 0..rgb.views.len() {
        let planes = rgb.planes(Some(k));
        write_exr_rgb(&dir.join(format!("view_{k:03}.exr")), w, h, planes)?;
        write_png_tonemapped_rgb(
            &dir.join(format!("view_{k:03}.png")),
            w,
            h,
            planes,
            Some(expo),
        )?;
    }
    Ok(())
}
