//! `pn solve`: solves a scene and writes fluence, moments, an image and a report.
//!
//! `pn solve checkerboard` with no further flags is the main job: P_5, 71×71, Neumann
//! (extrapolation) boundary, relative residual 1e-10.

use anyhow::{bail, Context};
use clap::Args;
use pn_kernels::Dim;
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
#[derive(Args, Debug, Clone)]
pub struct SolveArgs {
    /// A built-in scene (checkerboard, checkerboard3d, pointsource) or a .toml scene file.
    pub scene: String,
    /// Everything else (boxed: keeps the `pn` command enum small).
    #[command(flatten)]
    pub flags: Box<SolveFlags>,
}

/// The options of `pn solve`.
#[derive(Args, Debug, Clone)]
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
    /// pn (the P_N equations), cda (classical diffusion) or fld (flux-limited diffusion).
    #[arg(long, default_value = "pn", value_parser = ["pn", "cda", "fld"])]
    pub method: String,
    /// --method fld: flux limiter (lp, sum, max, kershaw, larsen2 or larsen<n>, cda;
    /// default lp).
    #[arg(long)]
    pub limiter: Option<String>,
    /// --method fld --fld-solver gs: SOR factor ω in (0, 2) (default 1.5).
    #[arg(long)]
    pub omega: Option<f64>,
    /// --method fld: gs (red–black Gauss–Seidel/SOR, default) or picard (linear solves
    /// through the diffusion stencil with --solver).
    #[arg(long, value_parser = ["gs", "picard"])]
    pub fld_solver: Option<String>,
    /// --method fld: extinction threshold σ_ε (1/length; default 1e-3 / longest domain edge).
    #[arg(long)]
    pub sigma_eps: Option<f64>,
    /// Linear solver: parity-cg (eliminates the odd moments; preconditioned CG, or GMRES/
    /// BiCGSTAB when the closure makes the even system nonsymmetric; the preconditioner is
    /// multigrid for large systems, ILU(0) for small ones), parity-mg / parity-ilu (force
    /// multigrid / the ILU(0)-or-Jacobi choice) or cgnr (the paper's baseline, CG on
    /// AᵀA u = Aᵀb); also lsqr, lsmr, and the matrix-free cgnr-mf, lsqr-mf, lsmr-mf.
    #[arg(long, default_value = "parity-cg")]
    pub solver: SolverKind,
    /// Raise σ_t to at least this value (required where σ_t reaches 0).
    #[arg(long)]
    pub sigma_t_min: Option<f64>,
    /// Refuse problems whose estimated memory exceeds this (bytes, or with K/M/G/T;
    /// default: 80% of the physical memory).
    #[arg(long, value_parser = pn_runtime::memory_estimate::parse_size)]
    pub max_memory: Option<u64>,
    /// Analytic fields: exact (value at the staggered point, as StaRMAP) or average[:N]
    /// (mean over the cell-sized control volume, N midpoints per axis; default 8 in 2D,
    /// 4 in 3D).
    #[arg(long, default_value = "exact")]
    pub sampling: pn_runtime::field::Sampling,
    /// Also solve at half the resolution and report a Richardson estimate of the
    /// discretization error (error.npy, error.png, report.json); needs even resolutions.
    #[arg(long)]
    pub error_estimate: bool,
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
    if a.method == "fld" {
        // Issue 9: the memory check before FLD allocates its per-cell arrays.
        let grid = scene_from_args(args)?.problem.grid;
        pn_runtime::memory_estimate::check_limit(
            &pn_runtime::memory_estimate::estimate_fld(&grid),
            a.max_memory
                .unwrap_or_else(pn_runtime::memory_estimate::default_limit_bytes),
        )?;
        return super::fld_method::run(args);
    }
    super::fld_method::reject_fld_flags(a)?;
    anyhow::ensure!(
        a.tol.is_finite() && a.tol > 0.0,
        "--tol must be positive, got {}",
        a.tol
    );
    anyhow::ensure!(a.max_iter > 0, "--max-iter must be at least 1");
    let mut scene = scene_from_args(args)?;
    for n in &scene.notes {
        eprintln!("note: {n}");
    }
    // `--method` is pn or cda here (clap allows pn, cda and fld; fld returned above).
    let (choice, order) = super::error_estimate::kernel_for(a, &scene)?;
    let opts = SolverOptions {
        tol: a.tol,
        max_iter: a.max_iter,
        ..Default::default()
    };
    // Issue 9: refuse oversized problems before allocating, then the automatic σ_t threshold.
    if let Some(t) =
        super::error_estimate::check_memory_and_set_sigma_t_min(a, &mut scene, &choice)?
    {
        eprintln!("note: σ_t = 0 in part of the domain (vacuum): using --sigma-t-min {t:.3e} (1e-3 × max σ_t); set --sigma-t-min to override");
    }
    super::error_estimate::check_args(args, &scene.problem.grid)?;
    let sampled = super::error_estimate::sampled_problem(&scene.problem, a.sampling);
    let problem = &sampled;
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
    super::error_estimate::after_solve(args, problem, &sol, &out)?;
    if scene.name == "pointsource" {
        super::pointsource_extras::write_extras(&out, a, &problem.grid, &sol, order)?;
    }

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
