//! Preconditioned conjugate gradients for a symmetric positive definite operator.
//!
//! Iterates on the true (unpreconditioned) residual `r = f − A x` and stops when
//! `‖r‖₂ ≤ target` ([`Control`]); starts from the given `x`, so the caller can restart
//! from the true residual when rounding drift leaves the recomputed residual above the
//! tolerance. No parameters beyond the controller's.
//!
//! ```
//! use pn_krylov::operator::Identity;
//! use pn_krylov::cg::cg;
//! use pn_krylov::control::{Control, Outcome};
//!
//! // A = [[4, 1], [1, 3]] (symmetric positive definite), f = A [1, 2].
//! let a = sprs::CsMat::new((2, 2), vec![0, 2, 4], vec![0, 1, 0, 1], vec![4.0, 1.0, 1.0, 3.0]);
//! let f = [6.0, 7.0];
//! let mut x = [0.0; 2];
//! // Target ‖f − A x‖ ≤ 1e-12 (absolute), residuals recorded relative to 1; at most 10
//! // iterations, stagnation window 10 with a required drop of 1e-4, divergence above 1e8.
//! let mut ctl = Control::new(1e-12, 1.0, 10, 10, 1e-4, 1e8);
//! assert_eq!(cg(&a, &Identity, &f, &mut x, &mut ctl), Outcome::Reached);
//! assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 2.0).abs() < 1e-12);
//! assert!(ctl.iterations <= 2); // CG is exact after n steps
//! ```

use crate::control::{true_residual, Control, Outcome};
use crate::linalg::{axpy, dot, norm, xpby};
use crate::operator::{LinearOperator, Preconditioner};

/// Preconditioned CG on `a x = f` from `x` with the preconditioner `m` (symmetric positive
/// definite). Returns [`Outcome::Stagnated`] when `a` or `m` turn out not to be positive
/// definite along a search direction.
pub fn cg(
    a: &dyn LinearOperator,
    m: &dyn Preconditioner,
    f: &[f64],
    x: &mut [f64],
    ctl: &mut Control,
) -> Outcome {
    let n = f.len();
    let mut r = vec![0.0; n];
    true_residual(a, f, x, &mut r, ctl);
    if let Some(o) = ctl.before_start(norm(&r)) {
        return o;
    }
    let mut z = vec![0.0; n];
    m.apply(&r, &mut z);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut q = vec![0.0; n];
    loop {
        a.apply(&p, &mut q);
        ctl.applications += 1;
        let pq = dot(&p, &q);
        if pq <= 0.0 || !pq.is_finite() || rz == 0.0 {
            // A (or M) is not positive definite along p, or an exact zero residual.
            return if norm(&r) <= ctl.target {
                Outcome::Reached
            } else {
                Outcome::Stagnated
            };
        }
        let alpha = rz / pq;
        axpy(alpha, &p, x);
        axpy(-alpha, &q, &mut r);
        if let Some(o) = ctl.record(norm(&r)) {
            return o;
        }
        m.apply(&r, &mut z);
        let rz_new = dot(&r, &z);
        let beta = rz_new / rz;
        rz = rz_new;
        xpby(&z, beta, &mut p);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use sprs::CsMat;

    /// The tridiagonal `n × n` matrix `(lower, diag, upper)`.
    pub(crate) fn tridiag(n: usize, lower: f64, diag: f64, upper: f64) -> CsMat<f64> {
        let mut tri = sprs::TriMat::new((n, n));
        for i in 0..n {
            if i > 0 {
                tri.add_triplet(i, i - 1, lower);
            }
            tri.add_triplet(i, i, diag);
            if i + 1 < n {
                tri.add_triplet(i, i + 1, upper);
            }
        }
        tri.to_csr()
    }

    /// Solves the tridiagonal system `(lower, 3, upper)` of size 50 with `method` and
    /// checks the solution and the controller's bookkeeping.
    pub(crate) fn check(
        method: impl Fn(&dyn LinearOperator, &mut [f64], &[f64], &mut Control) -> Outcome,
        lower: f64,
        upper: f64,
    ) {
        let n = 50;
        let a = tridiag(n, lower, 3.0, upper);
        let want: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut f = vec![0.0; n];
        a.apply(&want, &mut f);
        let target = 1e-12 * norm(&f);
        let mut ctl = Control::new(target, norm(&f), 1000, 100, 1e-4, 1e8);
        let mut x = vec![0.0; n];
        let out = method(&a, &mut x, &f, &mut ctl);
        assert_eq!(out, Outcome::Reached);
        // ‖x − x*‖ ≤ ‖A⁻¹‖ ‖r‖ with ‖A⁻¹‖ ≤ 1 (diagonally dominant by ≥ 1).
        let err = x
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-10, "error {err:e}");
        assert!(ctl.applications > 0 && ctl.iterations == ctl.history.len());
    }

    #[test]
    fn cg_solves_spd() {
        let id = crate::operator::Identity;
        check(|a, x, f, ctl| cg(a, &id, f, x, ctl), -1.0, -1.0);
    }
}
