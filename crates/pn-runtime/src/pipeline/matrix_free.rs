//! The pipeline's matrix-free route: problem → [`MatFreeOperator`] → Krylov solve →
//! un-stagger → energy balance, without ever assembling `A` (the `-mf` solvers).

use super::{check_magnitude_values, finish, solve_with_scaled_rhs, Solution, Solved};
use crate::energy::energy_balance;
use crate::layout::Layout;
use crate::matfree::MatFreeOperator;
use crate::problem::Problem;
use crate::solver::{SolveStats, SolverKind, SolverOptions};
use pn_krylov::operator::LinearOperator;
use pn_krylov::{cgls, lsmr, lsqr, Stopping};
use pn_stencil::StencilKernel;
use std::time::Instant;

/// Runs the matrix-free solver `kind` on `op` (any non-`-mf` kind is an error).
pub fn solve_operator(
    kind: SolverKind,
    op: &dyn LinearOperator,
    b: &[f64],
    opts: &SolverOptions,
) -> anyhow::Result<(Vec<f64>, SolveStats)> {
    type Run = fn(&dyn LinearOperator, &[f64], &Stopping, &str) -> (Vec<f64>, SolveStats);
    let run: Run = match kind {
        SolverKind::CgnrMf => cgls::cgls,
        SolverKind::LsqrMf => lsqr::lsqr,
        SolverKind::LsmrMf => lsmr::lsmr,
        _ => anyhow::bail!("solver {} needs an assembled matrix", kind.name()),
    };
    let stopping = opts.stopping();
    Ok(solve_with_scaled_rhs(b, |b| {
        run(op, b, &stopping, kind.name())
    }))
}

/// [`super::solve_problem`] without assembly: builds the matrix-free operator
/// (its time is reported as `seconds_assembly`), solves with the `-mf` solver `kind`, and
/// un-staggers. `nonzeros` reports the number of stored (position-dependent) weights (0
/// for a homogeneous medium), not the non-zeros of `A`. The energy balance uses the boundary
/// faces of L_1 (P_N); for stencils without them (CDA) it is left out.
pub fn solve_problem_matrix_free(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    kind: SolverKind,
    opts: &SolverOptions,
) -> anyhow::Result<Solution> {
    anyhow::ensure!(
        kind.is_matrix_free(),
        "solver {} is not matrix-free",
        kind.name()
    );
    problem.validate()?;
    problem.check_not_singular()?;
    let layout = Layout::new(&problem.grid, kernel.moments())?;
    let t0 = Instant::now();
    let op = MatFreeOperator::new(problem, kernel, &layout)?;
    let seconds_assembly = t0.elapsed().as_secs_f64();
    check_magnitude_values(op.max_weight(), true, op.rhs())?;
    let t1 = Instant::now();
    let (u, stats) = solve_operator(kind, &op, op.rhs(), opts)?;
    let seconds_solve = t1.elapsed().as_secs_f64();
    // Without A only the faces route (L_1 at the boundary) is available; stencils without
    // L_1 moments get no balance.
    let energy = energy_balance(problem, &layout, None, &u);
    let solved = Solved {
        u,
        stats,
        energy,
        nonzeros: op.stored_weights(),
        seconds_assembly,
        seconds_solve,
    };
    finish(problem, layout, solved)
}
