//! `--solver cgnr`: [CGLS](pn_krylov::cgls) on the assembled matrix.
//!
//! `A` and `Aᵀ` are each kept as CSR so that both products are row-parallel, both with
//! 32-bit column indices ([`pn_krylov::linalg::CsrOperator`]), since the products are
//! memory-bound.

use super::{LinearSolver, SolveStats, SolverOptions};
use pn_krylov::operator::AssembledOperator;
use sprs::CsMat;

/// The CGNR / CGLS solver.
pub struct Cgnr;

impl LinearSolver for Cgnr {
    fn name(&self) -> &'static str {
        "cgnr"
    }

    /// The CGLS iteration of [`pn_krylov::cgls::cgls`] on the assembled matrix and its
    /// transpose (both compact CSR, see [`AssembledOperator`]).
    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats) {
        pn_krylov::cgls::cgls(&AssembledOperator::new(a), b, &opts.stopping(), self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::SolveStatus;

    #[test]
    fn solves_a_nonsymmetric_system() {
        // A = [[4, 1, 0], [-2, 3, 1], [0, -1, 2]], x = [1, 2, 3].
        let a = CsMat::new(
            (3, 3),
            vec![0, 2, 5, 7],
            vec![0, 1, 0, 1, 2, 1, 2],
            vec![4.0, 1.0, -2.0, 3.0, 1.0, -1.0, 2.0],
        );
        let b = [6.0, 7.0, 4.0];
        let opts = SolverOptions {
            tol: 1e-12,
            ..Default::default()
        };
        let (x, st) = Cgnr.solve(&a, &b, &opts);
        assert!(st.converged(), "{st:?}");
        for (xi, want) in x.iter().zip([1.0, 2.0, 3.0]) {
            assert!((xi - want).abs() < 1e-10);
        }
        assert!(st.relative_residual <= 1e-12);
    }

    #[test]
    fn inconsistent_system_is_not_converged() {
        // Singular A = [[1, 1], [1, 1]] with b outside its range.
        let a = CsMat::new(
            (2, 2),
            vec![0, 2, 4],
            vec![0, 1, 0, 1],
            vec![1.0, 1.0, 1.0, 1.0],
        );
        let opts = SolverOptions {
            tol: 1e-12,
            ..Default::default()
        };
        let (_, st) = Cgnr.solve(&a, &[1.0, -1.0], &opts);
        assert_ne!(st.status, SolveStatus::Converged);
        assert!((st.relative_residual - 1.0).abs() < 1e-12);
    }
}
