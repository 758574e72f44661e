//! From a problem and a stencil kernel to a solution at cell centres:
//! layout → assembly → solve → un-stagger → energy balance.

use crate::assemble::assemble;
use crate::energy::{energy_balance, EnergyBalance};
use crate::layout::Layout;
use crate::problem::Problem;
use crate::solver::{SolveStats, SolverKind, SolverOptions};
use crate::unstagger::{unstagger, CellMoments};
use pn_codegen::stencil::StencilKernel;
use std::time::Instant;

/// Everything a solve produced.
pub struct Solution {
    /// The unknown layout.
    pub layout: Layout,
    /// The staggered solution vector.
    pub u: Vec<f64>,
    /// All moments at cell centres.
    pub moments: CellMoments,
    /// Solver statistics.
    pub stats: SolveStats,
    /// Energy balance (None if the stencil has no centred L_0^0).
    pub energy: Option<EnergyBalance>,
    /// Unknowns.
    pub unknowns: usize,
    /// Stored non-zeros of A.
    pub nonzeros: usize,
    /// Seconds spent assembling.
    pub seconds_assembly: f64,
    /// Seconds spent in the solver.
    pub seconds_solve: f64,
}

impl Solution {
    /// L_0^0 at cell centres, x slowest (C order of `(nx, ny, nz)`).
    pub fn l00(&self) -> Vec<f64> {
        self.moments.component(0)
    }
}

/// Assembles and solves `problem` with `kernel`.
///
/// Fails on invalid input (coefficients, kernel/grid mismatch) and when the solver
/// diverged; a solve that stopped before the tolerance returns `Ok` with a non-converged
/// status in [`Solution::stats`].
pub fn solve_problem(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    solver: SolverKind,
    opts: &SolverOptions,
) -> anyhow::Result<Solution> {
    problem.validate()?;
    let layout = Layout::new(&problem.grid, kernel.moments())?;
    let t0 = Instant::now();
    let system = assemble(problem, kernel, &layout)?;
    let seconds_assembly = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let (u, stats) = solver.solver().solve(&system.matrix, &system.rhs, opts);
    let seconds_solve = t1.elapsed().as_secs_f64();
    if stats.status == crate::solver::SolveStatus::Diverged {
        anyhow::bail!(
            "the {} solver diverged after {} iterations (relative residual {:.3e})",
            stats.solver,
            stats.iterations,
            stats.relative_residual
        );
    }
    let moments = unstagger(&problem.grid, &layout, &u);
    let energy = energy_balance(problem, &layout, &system.matrix, &u);
    Ok(Solution {
        unknowns: layout.len(),
        nonzeros: system.matrix.nnz(),
        layout,
        u,
        moments,
        stats,
        energy,
        seconds_assembly,
        seconds_solve,
    })
}
