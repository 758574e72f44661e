//! FLD: flux-limited diffusion (Levermore–Pomraning limiter) on cubic solve cells, by
//! `[solve] fld_solver` — Picard steps on multigrid CG, or nonlinear Gauss–Seidel
//! ([`crate::fld_problem`]); the fluence handed to the renderer as L_0^0.

use super::super::report::SolverReport;
use super::grid::{solve_on_grid, GridMethod, GridSolve};
use super::{MsSolution, MultipleScattering, PreparedScene};
use crate::fld_problem::{fld_problem, solve_fld_route, FldSettings, Route, SQRT_4PI};
use crate::scene::FldSolver;
use anyhow::{ensure, Context, Result};
use pn_kernels::{diffusion_kernel, Dim};
use pn_runtime::fld::{FldParams, Limiter};
use pn_runtime::problem::Problem;
use pn_runtime::solver::SolverKind;
use pn_runtime::CellMoments;

/// Flux-limited diffusion.
pub struct Fld;

impl MultipleScattering for Fld {
    fn name(&self) -> &str {
        "fld"
    }

    fn delta_m_order(&self) -> Option<u32> {
        Some(1)
    }

    fn solve(&self, p: &PreparedScene<'_>) -> Result<MsSolution> {
        let method = GridMethod {
            kernel: None,
            max_band: 0,
            solve_band: 0,
            uses_sigma_t_min: false,
            correction: None,
        };
        solve_on_grid(p, &method, &|problem, notes| solve_fld(p, problem, notes))
    }
}

/// Solves the FLD problem of `problem` by the scene's route; returns the cell-centred L_0^0.
fn solve_fld(
    p: &PreparedScene<'_>,
    problem: &Problem,
    notes: &mut Vec<String>,
) -> Result<GridSolve> {
    let tol = p.scene.solve.tolerance;
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
        route: match p.scene.solve.fld_solver {
            FldSolver::Picard => Route::Picard,
            FldSolver::Gs => Route::GaussSeidel,
        },
        linear_solver: SolverKind::ParityCg,
        tuning: p.options.tuning.clone(),
    };
    let dk = diffusion_kernel(Dim::Three)?;
    let run = solve_fld_route(&fp, &settings, &dk, None)?;
    notes.extend(run.notes.iter().cloned());
    let s = &run.solution;
    if !s.converged {
        notes.push(format!(
            "warning: FLD stopped at relative residual {:.3e} after {} iterations",
            s.final_residual(),
            s.iterations
        ));
    }
    let moments = CellMoments {
        res: problem.grid.res,
        per_cell: 1,
        data: s.phi.iter().map(|v| v / SQRT_4PI).collect(),
    };
    Ok(GridSolve {
        moments,
        staggered: None,
        report: SolverReport {
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
    })
}
