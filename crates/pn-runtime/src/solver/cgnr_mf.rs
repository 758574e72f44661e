//! `--solver cgnr-mf`: [`cgls`] with the matrix-free operator
//! ([`crate::matfree`]); the pipeline routes it there so that `A` is never assembled.

use super::{LinearSolver, SolveStats, SolverOptions};
pub use pn_krylov::cgls::cgls;
use pn_krylov::operator::AssembledOperator;
use sprs::CsMat;

/// CGLS with the matrix-free operator; given an assembled matrix (through
/// [`LinearSolver`]) it runs on that matrix, which is the same iteration as `cgnr`.
pub struct CgnrMf;

impl LinearSolver for CgnrMf {
    fn name(&self) -> &'static str {
        "cgnr-mf"
    }
    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats) {
        cgls(&AssembledOperator::new(a), b, &opts.stopping(), self.name())
    }
}
