//! The FLD problem of a transport problem and its solve by either route ([`Route`]), shared
//! by `pn render --method fld` ([`crate::pipeline::methods::fld`]) and `pn solve --method
//! fld` (the drivers' `fld_setup`, which reads the command line's FLD settings).
//!
//! **From the scene to the FLD problem** ([`fld_problem`]): σ_t, σ_s (or the albedo) and
//! `Q_0^0` are evaluated at the cell centres (exact for analytic fields, the voxel itself for
//! voxel data at the grid resolution). The FLD extinction is the transport coefficient
//! `σ_t − g σ_s` (`g = λ_1 p_1`, docs/design.md §2.2; σ_t for isotropic scattering), the
//! absorption `σ_t − σ_s`. FLD needs cubic cells (one `h`) and 3D.
//!
//! **Normalisation.** The FLD solvers work with the fluence `φ = √(4π) L_0^0` and the
//! isotropic emission `q = √(4π) Q_0^0` ([`SQRT_4PI`]).

use anyhow::{bail, ensure, Context, Result};
use pn_kernels::{Dim, KernelChoice};
use pn_runtime::fld::{
    solve_fld_from, solve_fld_picard, FldGrid, FldParams, FldProblem, FldSolution, PicardOptions,
};
use pn_runtime::problem::{Problem, Scattering};
use pn_runtime::solver::{SolverKind, SolverTuning};
use std::time::Instant;

/// `√(4π)`: `φ = √(4π) L_0^0` and `q = √(4π) Q_0^0` (docs/design.md §1).
pub const SQRT_4PI: f64 = 3.544_907_701_811_032;

/// How the nonlinear FLD system is solved (`pn solve --method fld --fld-solver`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Route {
    /// Nonlinear red–black Gauss–Seidel with SOR ([`pn_runtime::fld::solve_fld`]).
    GaussSeidel,
    /// Picard iteration, each step a linear solve through the `diffusion_3d` stencil
    /// ([`pn_runtime::fld::solve_fld_picard`]), Anderson-accelerated. The default: on the
    /// 63³ point source 1.7 s against 10.6 s for Gauss–Seidel (docs/fld.md).
    #[default]
    Picard,
}

impl Route {
    /// `gs` or `picard`.
    pub fn name(self) -> &'static str {
        match self {
            Route::GaussSeidel => "gs",
            Route::Picard => "picard",
        }
    }
}

impl std::str::FromStr for Route {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "gs" => Ok(Route::GaussSeidel),
            "picard" => Ok(Route::Picard),
            _ => bail!("unknown FLD solver {s:?} (expected gs or picard)"),
        }
    }
}

/// The settings of an FLD solve.
#[derive(Clone, Debug, PartialEq)]
pub struct FldSettings {
    /// Limiter, ω, tolerance, σ_ε, ε, iteration limit.
    pub params: FldParams,
    /// The solver route.
    pub route: Route,
    /// The linear solver of the Picard steps.
    pub linear_solver: SolverKind,
    /// Expert settings of that linear solver.
    pub tuning: SolverTuning,
}

/// The cubic-cell grid of a 3D scene grid (FLD uses one spacing h).
pub fn fld_grid(problem: &Problem) -> Result<FldGrid> {
    let g = &problem.grid;
    ensure!(
        g.dim == Dim::Three,
        "--method fld is 3D only (the FLD solvers work on cubic cells in 3D); use --dim 3"
    );
    let h = g.h(0);
    for d in 1..3 {
        ensure!(
            (g.h(d) - h).abs() <= 1e-9 * h,
            "--method fld needs cubic cells, got h = ({}, {}, {}); choose --res proportional \
             to the domain extents",
            g.h(0),
            g.h(1),
            g.h(2)
        );
    }
    FldGrid::new(g.res, h).context("--method fld")
}

/// The FLD problem of a scene: fields at the cell centres, transport extinction, fluence
/// source `q = √(4π) Q_0^0` (see the module documentation).
pub fn fld_problem(problem: &Problem) -> Result<FldProblem> {
    problem.validate()?;
    let grid = fld_grid(problem)?;
    let g = &problem.grid;
    let len = grid.len();
    let (mut sigma_t, mut sigma_a, mut source) = (vec![0.0; len], vec![0.0; len], vec![0.0; len]);
    let g1 = problem.phase.moment(1);
    for (c, ((st, sa), q)) in sigma_t
        .iter_mut()
        .zip(sigma_a.iter_mut())
        .zip(source.iter_mut())
        .enumerate()
    {
        let cell = grid.cell(c);
        let p = [0, 1, 2].map(|d| g.coord(d, 2 * cell[d] as i64 + 1));
        let t = problem.sigma_t.eval(p);
        let s = match &problem.scattering {
            Scattering::SigmaS(f) => f.eval(p),
            Scattering::Albedo(f) => f.eval(p) * t,
        };
        let at = || format!("at ({:.6}, {:.6}, {:.6})", p[0], p[1], p[2]);
        ensure!(
            t.is_finite() && t >= 0.0,
            "σ_t = {t} {}: must be finite and non-negative",
            at()
        );
        ensure!(
            s.is_finite() && s >= 0.0,
            "σ_s = {s} {}: must be finite and non-negative",
            at()
        );
        ensure!(
            s <= t * (1.0 + 1e-12),
            "σ_s = {s} exceeds σ_t = {t} {} (albedo > 1)",
            at()
        );
        let s = s.min(t);
        *st = pn_runtime::problem::sigma_tr(t, s, g1);
        *sa = t - s;
        let q00 = problem.source(0, 0, p).map_err(anyhow::Error::from)?;
        ensure!(q00 >= 0.0, "source Q_0^0 = {q00} {} is negative", at());
        *q = SQRT_4PI * q00;
    }
    Ok(FldProblem {
        grid,
        sigma_t,
        sigma_a,
        source,
    })
}

/// What an FLD solve by either route produced.
#[derive(Clone, Debug, PartialEq)]
pub struct FldRun {
    /// φ, iterations (Gauss–Seidel iterations or Picard steps), residual history.
    pub solution: FldSolution,
    /// The route taken.
    pub route: Route,
    /// Linear iterations per Picard step (empty for Gauss–Seidel).
    pub linear_iterations: Vec<usize>,
    /// Linear solver of the Picard steps (None for Gauss–Seidel).
    pub linear_solver: Option<String>,
    /// Stored non-zeros of the operator (7-point stencil at the interior cells).
    pub nonzeros: usize,
    /// Seconds spent solving.
    pub seconds: f64,
    /// What the solve wants its caller to know (per-step timings of a profile).
    pub notes: Vec<String>,
}

/// Solves `problem` by `settings.route`, from `initial` if given. For the Picard route
/// `kernel` is the diffusion stencil.
pub fn solve_fld_route(
    problem: &FldProblem,
    settings: &FldSettings,
    kernel: &KernelChoice,
    initial: Option<&[f64]>,
) -> Result<FldRun> {
    let t0 = Instant::now();
    let run = match settings.route {
        Route::GaussSeidel => {
            let solution = solve_fld_from(problem, &settings.params, initial)?;
            FldRun {
                solution,
                route: Route::GaussSeidel,
                linear_iterations: Vec::new(),
                linear_solver: None,
                nonzeros: interior_nonzeros(problem.grid.n),
                seconds: 0.0,
                notes: Vec::new(),
            }
        }
        Route::Picard => {
            let opts = PicardOptions {
                solver: settings.linear_solver,
                max_steps: settings.params.max_iter,
                tuning: settings.tuning.clone(),
                ..Default::default()
            };
            let p = solve_fld_picard(
                problem,
                &settings.params,
                kernel.kernel.as_ref(),
                &opts,
                initial,
            )?;
            FldRun {
                solution: p.fld,
                route: Route::Picard,
                linear_iterations: p.linear_iterations,
                linear_solver: Some(p.solver),
                nonzeros: if p.nonzeros > 0 {
                    p.nonzeros
                } else {
                    interior_nonzeros(problem.grid.n)
                },
                seconds: 0.0,
                notes: p.notes,
            }
        }
    };
    Ok(FldRun {
        seconds: t0.elapsed().as_secs_f64(),
        ..run
    })
}

/// Non-zeros of the 7-point operator on the interior cells (couplings to the boundary layer
/// are known values, not unknowns).
fn interior_nonzeros(n: [usize; 3]) -> usize {
    let m = n.map(|v| v - 2);
    let cells = m[0] * m[1] * m[2];
    let links: usize = (0..3)
        .map(|d| (m[d] - 1) * m[(d + 1) % 3] * m[(d + 2) % 3])
        .sum();
    cells + 2 * links
}
