//! ILU(0)-preconditioned GMRES on the assembled `A`: what the parity solvers fall back to
//! for systems without the parity structure of docs/design.md §5 (text PDEs such as SP_3,
//! whose diffusion equations couple unknowns of the same parity; collocated stencils).
//!
//! The preconditioner is the incomplete LU factorisation of `A` on its own pattern
//! ([`Ilu0`], the one the parity solvers use on the reduced system), applied from the right
//! ([`pn_krylov::gmres`]), so the tolerance is on the true residual `‖b − Au‖₂/‖b‖₂`. When the
//! factorisation meets a zero pivot or GMRES does not reach the tolerance, CGNR (the
//! paper's baseline, robust for any non-singular `A`) takes over from zero.

use super::precond::Ilu0;
use crate::solver::cgnr::Cgnr;
use crate::solver::{LinearSolver, SolveStats, SolveStatus, SolverOptions};
use pn_krylov::control::run_from_zero;
use pn_krylov::operator::AssembledOperator;
use sprs::CsMat;

/// GMRES with ILU(0) on `a u = b` from zero; `None` when ILU(0) breaks down or GMRES
/// stops short of the tolerance.
pub fn gmres_ilu(
    a: &CsMat<f64>,
    b: &[f64],
    opts: &SolverOptions,
) -> Option<(Vec<f64>, SolveStats)> {
    let ilu = Ilu0::new(a).ok()?;
    let op = AssembledOperator::new(a);
    let (x, stats) = run_from_zero(
        &op,
        b,
        &opts.stopping(),
        "gmres-ilu",
        |a, _bnorm, x, ctl| pn_krylov::gmres::gmres(a, &ilu, b, x, ctl).status(),
    );
    (stats.status == SolveStatus::Converged).then_some((x, stats))
}

/// The fallback for a system the parity solver cannot take (`why`): [`gmres_ilu`], else
/// CGNR; the statistics' notes say which one ran.
pub fn fallback(
    a: &CsMat<f64>,
    b: &[f64],
    opts: &SolverOptions,
    why: &str,
) -> (Vec<f64>, SolveStats) {
    let ilu_note = format!(
        "note: parity-cg does not apply ({why}); solving A u = b with ILU(0)-preconditioned GMRES"
    );
    if let Some((u, stats)) = gmres_ilu(a, b, opts) {
        return (u, stats.with_note(ilu_note));
    }
    let (u, stats) = Cgnr.solve(a, b, opts);
    let stats = stats
        .with_note(ilu_note)
        .with_note("note: ILU(0)-GMRES did not converge; falling back to cgnr");
    (u, stats)
}
