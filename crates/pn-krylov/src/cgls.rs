//! CGLS: conjugate gradients on the normal equations `AᵀA u = Aᵀb` without forming `AᵀA`
//! (Hestenes & Stiefel 1952; docs/design.md §5), on any [`LinearOperator`]: the assembled CSR
//! matrix (`--solver cgnr`, [`super::cgnr::Cgnr`]) or the matrix-free operator
//! (`--solver cgnr-mf`, `pn_runtime::MatFreeOperator`).
//!
//! Per iteration one product with `A` and one with `Aᵀ`. CGLS minimises `‖b − Au‖₂` over
//! the Krylov space, so the recurrence residual decreases monotonically; when it meets the
//! tolerance the true residual is recomputed and, if it is still above the tolerance
//! (rounding drift), the iteration restarts from the true residual (at most
//! [`crate::control::MAX_RESTARTS`] times, then "stagnated"). No parameters beyond the
//! controller's; the info is [`SolveStats`].

use crate::control::{run_from_zero, Outcome};
use crate::linalg::{axpy, dot, norm, xpby};
use crate::operator::{op_residual, LinearOperator};
use crate::stats::{SolveStats, SolveStatus, Stopping};

/// CGLS on `a u = b` from u = 0, reported as solver `name`.
pub fn cgls(
    a: &dyn LinearOperator,
    b: &[f64],
    opts: &Stopping,
    name: &str,
) -> (Vec<f64>, SolveStats) {
    run_from_zero(a, b, opts, name, |a, _bnorm, x, ctl| {
        let n = a.cols();
        let mut r = b.to_vec();
        let mut s = vec![0.0; n];
        a.apply_transpose(&r, &mut s);
        let mut p = s.clone();
        let mut gamma = dot(&s, &s);
        let mut q = vec![0.0; a.rows()];
        let mut status = SolveStatus::MaxIterations;
        while ctl.iterations < opts.max_iter {
            a.apply(&p, &mut q);
            let delta = dot(&q, &q);
            if delta == 0.0 || gamma == 0.0 {
                // Aᵀr = 0: the least-squares minimum is reached but b − Au ≠ 0.
                status = SolveStatus::Stagnated;
                break;
            }
            let alpha = gamma / delta;
            axpy(alpha, &p, x);
            axpy(-alpha, &q, &mut r);
            match ctl.record(norm(&r)) {
                None => {}
                Some(Outcome::Reached) => {
                    // Confirm with the true residual; restart from it if rounding drifted.
                    op_residual(a, x, b, &mut r);
                    if norm(&r) <= ctl.target {
                        status = SolveStatus::Converged;
                        break;
                    }
                    if !ctl.may_restart() {
                        status = SolveStatus::Stagnated;
                        break;
                    }
                    a.apply_transpose(&r, &mut s);
                    p.copy_from_slice(&s);
                    gamma = dot(&s, &s);
                    continue;
                }
                Some(o) => {
                    status = o.status();
                    break;
                }
            }
            a.apply_transpose(&r, &mut s);
            let gamma_new = dot(&s, &s);
            let beta = gamma_new / gamma;
            gamma = gamma_new;
            xpby(&s, beta, &mut p);
        }
        status
    })
}
