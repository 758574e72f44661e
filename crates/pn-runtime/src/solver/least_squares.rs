//! `--solver lsqr` and `--solver lsmr`: the least-squares methods of `pn_krylov` on the
//! assembled matrix (both products row-parallel through [`AssembledOperator`]).

use super::{LinearSolver, SolveStats, SolverOptions};
use pn_krylov::operator::AssembledOperator;
use sprs::CsMat;

/// LSQR (Paige–Saunders) on the assembled matrix ([`pn_krylov::lsqr`]).
pub struct Lsqr;

impl LinearSolver for Lsqr {
    fn name(&self) -> &'static str {
        "lsqr"
    }
    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats) {
        pn_krylov::lsqr::lsqr(&AssembledOperator::new(a), b, &opts.stopping(), self.name())
    }
}

/// LSMR (Fong–Saunders) on the assembled matrix ([`pn_krylov::lsmr`]).
pub struct Lsmr;

impl LinearSolver for Lsmr {
    fn name(&self) -> &'static str {
        "lsmr"
    }
    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats) {
        pn_krylov::lsmr::lsmr(&AssembledOperator::new(a), b, &opts.stopping(), self.name())
    }
}
