//! `pn solve`: solves a scene and writes fluence, moments, an image and a report.
//!
//! `pn solve checkerboard` with no further flags is the main job: P_5, 71×71, Neumann
//! (extrapolation) boundary, relative residual 1e-10.

use crate::stencils::{cda_kernel, pn_kernel, Dim, Layout};
use anyhow::{bail, Context};
use clap::Args;
use pn_runtime::output::report::{Report, RunInfo};
use pn_runtime::output::write_outputs;
use pn_runtime::pipeline::solve_problem;
use pn_runtime::problem::Boundary;
use pn_runtime::scene_file::load_scene;
use pn_runtime::scenes::{
    builtin, resolve_res, BuiltinOptions, PointSourceParams, PointSourceShape, Scene,
};
use pn_runtime::solver::{SolverKind, SolverOptions};
use std::path::{Path, PathBuf};

/// Arguments of `pn solve`.
#[derive(Args, Debug)]
pub struct SolveArgs {
    /// A built-in scene (checkerboard, checkerboard3d, pointsource) or a .toml scene file.
    pub scene: String,
    /// Everything else (boxed: keeps the `pn` command enum small).
    #[command(flatten)]
    pub flags: Box<SolveFlags>,
}

/// The options of `pn solve`.
#[derive(Args, Debug)]
pub struct SolveFlags {
    /// P_N order (default: the scene's, 5 for checkerboard).
    #[arg(long)]
    pub order: Option<usize>,
    /// Dimension, 2 or 3 (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u8).range(2..=3))]
    pub dim: Option<u8>,
    /// Cells per axis: one number for all axes, or NX,NY[,NZ].
    #[arg(long, value_delimiter = ',')]
    pub res: Option<Vec<usize>>,
    /// Boundary closure: neumann (extrapolation) or dirichlet (zero).
    #[arg(long)]
    pub bc: Option<Boundary>,
    /// Tolerance on the relative residual ‖b − Au‖₂/‖b‖₂.
    #[arg(long, default_value = "1e-10")]
    pub tol: f64,
    /// Maximum solver iterations.
    #[arg(long, default_value_t = 100_000)]
    pub max_iter: usize,
    /// Output directory (default: out/<scene>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Use the collocated stencil (all moments at cell centres; oscillates).
    #[arg(long)]
    pub collocated: bool,
    /// pn (the P_N equations) or cda (classical diffusion).
    #[arg(long, default_value = "pn", value_parser = ["pn", "cda"])]
    pub method: String,
    /// Linear solver.
    #[arg(long, default_value = "cgnr")]
    pub solver: SolverKind,
    /// Raise σ_t to at least this value (required where σ_t reaches 0).
    #[arg(long)]
    pub sigma_t_min: Option<f64>,
    /// pointsource: extinction σ_t (default 8).
    #[arg(long)]
    pub sigma_t: Option<f64>,
    /// pointsource: albedo (default 0.9).
    #[arg(long)]
    pub albedo: Option<f64>,
    /// pointsource: Henyey–Greenstein g (default 0, isotropic).
    #[arg(long)]
    pub g: Option<f64>,
    /// pointsource: the domain is [0, 2w]³ (default w = 1).
    #[arg(long)]
    pub half_width: Option<f64>,
    /// pointsource: cell (Q_0^0 = 1/h³ in cell n/2) or gaussian:<std-dev>.
    #[arg(long)]
    pub source: Option<PointSourceShape>,
}

/// Builds the scene named or pointed to by the arguments, with overrides applied.
pub fn scene_from_args(args: &SolveArgs) -> anyhow::Result<Scene> {
    let a = &*args.flags;
    let scene_arg = &args.scene;
    let dim = a.dim.map(|d| if d == 2 { Dim::Two } else { Dim::Three });
    let is_file = scene_arg.ends_with(".toml") || Path::new(scene_arg.as_str()).is_file();
    let ps_flags = a.sigma_t.is_some()
        || a.albedo.is_some()
        || a.g.is_some()
        || a.half_width.is_some()
        || a.source.is_some();
    if ps_flags && scene_arg != "pointsource" {
        bail!("--sigma-t, --albedo, --g, --half-width and --source only apply to the pointsource scene");
    }
    let mut scene = if is_file {
        let mut s = load_scene(Path::new(scene_arg.as_str()))?;
        let g = &mut s.problem.grid;
        if let Some(d) = dim {
            g.dim = d;
        }
        if a.res.is_some() || dim.is_some() {
            let current: Vec<usize> = g.res[..g.dim.axes()].to_vec();
            g.res = resolve_res(g.dim, 1, Some(a.res.as_deref().unwrap_or(&current)))?;
        }
        s
    } else {
        let d = PointSourceParams::default();
        let opts = BuiltinOptions {
            dim,
            res: a.res.clone(),
            pointsource: PointSourceParams {
                sigma_t: a.sigma_t.unwrap_or(d.sigma_t),
                albedo: a.albedo.unwrap_or(d.albedo),
                g: a.g.unwrap_or(d.g),
                half_width: a.half_width.unwrap_or(d.half_width),
                source: a.source.unwrap_or(d.source),
            },
        };
        builtin(scene_arg, &opts)?
    };
    if let Some(bc) = a.bc {
        scene.problem.boundary = bc;
    }
    if a.sigma_t_min.is_some() {
        scene.problem.sigma_t_min = a.sigma_t_min;
    }
    scene.problem.validate()?;
    Ok(scene)
}

/// Runs `pn solve`.
pub fn run(args: &SolveArgs) -> anyhow::Result<()> {
    let a = &*args.flags;
    anyhow::ensure!(
        a.tol.is_finite() && a.tol > 0.0,
        "--tol must be positive, got {}",
        a.tol
    );
    anyhow::ensure!(a.max_iter > 0, "--max-iter must be at least 1");
    let scene = scene_from_args(args)?;
    for n in &scene.notes {
        eprintln!("note: {n}");
    }
    let dim = scene.problem.grid.dim;
    let layout = if a.collocated {
        Layout::Collocated
    } else {
        Layout::Staggered
    };
    let (choice, order) = match a.method.as_str() {
        "cda" => {
            anyhow::ensure!(!a.collocated, "--collocated applies to --method pn only");
            anyhow::ensure!(a.order.is_none(), "--order applies to --method pn only");
            (cda_kernel(dim)?, 0)
        }
        _ => {
            let order = a.order.unwrap_or(scene.default_order);
            (pn_kernel(order, dim, layout)?, order)
        }
    };
    let opts = SolverOptions {
        tol: a.tol,
        max_iter: a.max_iter,
        ..Default::default()
    };
    let problem = &scene.problem;
    let kernel = choice.kernel.as_ref();
    let sol = pn_runtime::threads::with_threads(a.threads, || {
        solve_problem(problem, kernel, a.solver, &opts)
    })??;

    let info = RunInfo {
        scene: scene.name.clone(),
        method: a.method.clone(),
        order,
        layout: if a.collocated {
            "collocated"
        } else {
            "staggered"
        }
        .into(),
        stencil_compiled: choice.compiled,
        threads: pn_runtime::threads::effective_threads(a.threads),
    };
    let report = Report::new(&info, problem, kernel.name(), &sol);
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scene.name));
    write_outputs(&out, &problem.grid, &sol, &report)
        .with_context(|| format!("writing results to {}", out.display()))?;

    let g = &problem.grid;
    let res = g.res[..g.dim.axes()]
        .iter()
        .map(|n| n.to_string())
        .collect::<Vec<_>>()
        .join("×");
    let what = if a.method == "cda" {
        "CDA".to_string()
    } else {
        format!("P_{order}")
    };
    println!(
        "{} {what} {}D {res} {}: {} unknowns, {} non-zeros, {} iterations, relative residual {:.3e}, \
         assembly {:.3} s, solve {:.3} s -> {}",
        scene.name,
        g.dim.axes(),
        problem.boundary.name(),
        sol.unknowns,
        sol.nonzeros,
        sol.stats.iterations,
        sol.stats.relative_residual,
        sol.seconds_assembly,
        sol.seconds_solve,
        out.display()
    );
    if let Some(e) = &sol.energy {
        println!(
            "energy: source {:.6e} = absorbed {:.6e} + outflow {:.6e} (relative imbalance {:.2e})",
            e.source_power, e.absorbed_power, e.boundary_outflow, e.relative_imbalance
        );
    }
    if !sol.stats.converged() {
        bail!(
            "not converged ({:?}): relative residual {:.3e} after {} iterations, tolerance {:.1e}; \
             results were written to {} with \"converged\": false",
            sol.stats.status,
            sol.stats.relative_residual,
            sol.stats.iterations,
            a.tol,
            out.display()
        );
    }
    Ok(())
}
