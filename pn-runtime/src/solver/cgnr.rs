//! CG on the normal equations (CGLS form): AᵀA u = Aᵀb without forming AᵀA (DESIGN.md §5).
//!
//! Per iteration one product with A and one with Aᵀ (kept as its own CSR matrix so both
//! products are row-parallel; both stored with 32-bit column indices, see
//! [`CsrOperator`], since the products are memory-bound). CGLS minimises ‖b − Au‖₂ over
//! the Krylov space, so the recurrence residual decreases monotonically; when it meets the tolerance the true
//! residual is recomputed and, if it is still above the tolerance (rounding drift), the
//! iteration restarts from the true residual (at most a few times, then "stagnated").

use super::{progress_bar, LinearSolver, SolveStats, SolveStatus, SolverOptions};
use crate::linalg::{axpy, dot, norm, residual, transpose_csr, xpby, CsrOperator};
use sprs::CsMat;

/// The CGNR / CGLS solver.
pub struct Cgnr;

/// How many times the recurrence may be restarted from the true residual.
const MAX_REPLACEMENTS: usize = 3;

impl LinearSolver for Cgnr {
    fn name(&self) -> &'static str {
        "cgnr"
    }

    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats) {
        let n = a.cols();
        let atc = CsrOperator::new(transpose_csr(a));
        let ac = CsrOperator::from_ref(a);
        let bnorm = norm(b);
        let mut x = vec![0.0; n];
        let mut history = Vec::new();
        let finish = |x: Vec<f64>, status, iterations, history: Vec<f64>| {
            let mut r = vec![0.0; b.len()];
            residual(a, &x, b, &mut r);
            let abs = norm(&r);
            let rel = if bnorm > 0.0 { abs / bnorm } else { abs };
            let stats = SolveStats {
                solver: "cgnr".into(),
                status,
                iterations,
                relative_residual: rel,
                absolute_residual: abs,
                rhs_norm: bnorm,
                tolerance: opts.tol,
                history,
            };
            (x, stats)
        };
        if bnorm == 0.0 {
            return finish(x, SolveStatus::Converged, 0, history);
        }

        let mut r = b.to_vec();
        let mut s = vec![0.0; n];
        atc.mul(&r, &mut s);
        let mut p = s.clone();
        let mut gamma = dot(&s, &s);
        let mut q = vec![0.0; a.rows()];
        let mut best = 1.0f64;
        let mut best_at = 0usize;
        let mut replacements = 0usize;
        let pb = progress_bar(opts.max_iter, opts.progress);
        let mut status = SolveStatus::MaxIterations;
        let mut it = 0usize;
        while it < opts.max_iter {
            it += 1;
            ac.mul(&p, &mut q);
            let delta = dot(&q, &q);
            if delta == 0.0 || gamma == 0.0 {
                // Aᵀr = 0: the least-squares minimum is reached but b − Au ≠ 0.
                status = SolveStatus::Stagnated;
                break;
            }
            let alpha = gamma / delta;
            axpy(alpha, &p, &mut x);
            axpy(-alpha, &q, &mut r);
            let mut rel = norm(&r) / bnorm;
            history.push(rel);
            if it & 15 == 0 {
                pb.set_position(it as u64);
                pb.set_message(format!("relative residual {rel:.3e}"));
            }
            if !rel.is_finite() || rel > opts.divergence_limit {
                status = SolveStatus::Diverged;
                break;
            }
            if rel <= opts.tol {
                // Confirm with the true residual.
                residual(a, &x, b, &mut r);
                rel = norm(&r) / bnorm;
                if rel <= opts.tol {
                    status = SolveStatus::Converged;
                    break;
                }
                replacements += 1;
                if replacements > MAX_REPLACEMENTS {
                    status = SolveStatus::Stagnated;
                    break;
                }
                atc.mul(&r, &mut s);
                p.copy_from_slice(&s);
                gamma = dot(&s, &s);
                continue;
            }
            if rel < best * (1.0 - opts.stagnation_drop) {
                best = rel;
                best_at = it;
            } else if it - best_at >= opts.stagnation_window {
                status = SolveStatus::Stagnated;
                break;
            }
            atc.mul(&r, &mut s);
            let gamma_new = dot(&s, &s);
            let beta = gamma_new / gamma;
            gamma = gamma_new;
            xpby(&s, beta, &mut p);
        }
        pb.finish_and_clear();
        finish(x, status, it, history)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            progress: false,
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
            progress: false,
            ..Default::default()
        };
        let (_, st) = Cgnr.solve(&a, &[1.0, -1.0], &opts);
        assert_ne!(st.status, SolveStatus::Converged);
        assert!((st.relative_residual - 1.0).abs() < 1e-12);
    }
}
