//! CG on the normal equations (CGLS form) on any [`LinearOperator`]: the assembled CSR
//! matrix ([`super::cgnr::Cgnr`]) or the matrix-free operator (`--solver cgnr-mf`,
//! [`crate::matfree`]). Also the bookkeeping shared by the least-squares solvers
//! ([`super::lsqr`], [`super::lsmr`]): stopping on ‖b − Au‖₂/‖b‖₂ and the final
//! recomputed residual.
//!
//! CGLS minimises ‖b − Au‖₂ over the Krylov space, so the recurrence residual decreases
//! monotonically; when it meets the tolerance the true residual is recomputed and, if it is
//! still above the tolerance (rounding drift), the iteration restarts from the true residual
//! (at most a few times, then "stagnated").

use super::parity::krylov::{Control, Outcome};
use super::{progress_bar, LinearSolver, SolveStats, SolveStatus, SolverOptions};
use crate::linalg::{axpy, dot, norm, xpby};
use crate::operator::{op_residual, AssembledOperator, Counted, LinearOperator};
use sprs::CsMat;

/// CGLS with the matrix-free operator; given an assembled matrix (through
/// [`LinearSolver`]) it runs on that matrix, which is the same iteration as `cgnr`.
pub struct CgnrMf;

impl LinearSolver for CgnrMf {
    fn name(&self) -> &'static str {
        "cgnr-mf"
    }
    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats) {
        cgls(&AssembledOperator::new(a), b, opts, self.name())
    }
}

/// How many times the recurrence may be restarted from (or re-checked against) the true
/// residual.
pub(crate) const MAX_REPLACEMENTS: usize = 3;

/// Stopping rules of the solvers on `A u = b`, on top of the Krylov [`Control`].
pub(crate) struct Monitor<'a> {
    ctl: Control<'a>,
    bnorm: f64,
    pb: indicatif::ProgressBar,
}

impl Monitor<'_> {
    /// Records the recurrence estimate of ‖b − Au‖ after one iteration.
    pub(crate) fn record(&mut self, rnorm: f64) -> Option<Outcome> {
        let it = self.ctl.iterations + 1;
        if it & 15 == 0 {
            self.pb.set_position(it as u64);
            self.pb
                .set_message(format!("relative residual {:.3e}", rnorm / self.bnorm));
        }
        self.ctl.record(rnorm)
    }

    /// Iterations done.
    pub(crate) fn iterations(&self) -> usize {
        self.ctl.iterations
    }

    /// The absolute target tol·‖b‖.
    pub(crate) fn target(&self) -> f64 {
        self.ctl.target
    }
}

/// A monitor for `b` with `opts`.
pub(crate) fn monitor<'a>(
    bnorm: f64,
    opts: &SolverOptions,
    progress: &'a dyn Fn(usize, f64),
) -> Monitor<'a> {
    Monitor {
        ctl: Control::for_options(opts, bnorm, progress),
        bnorm,
        pb: progress_bar(opts.max_iter, opts.progress),
    }
}

/// Maps a run's outcome to the reported status.
pub(crate) fn status_of(outcome: Outcome) -> SolveStatus {
    match outcome {
        Outcome::Reached => SolveStatus::Converged,
        Outcome::MaxIterations => SolveStatus::MaxIterations,
        Outcome::Stagnated => SolveStatus::Stagnated,
        Outcome::Diverged => SolveStatus::Diverged,
    }
}

/// The stats of a finished run, with the residual recomputed from `x`.
pub(crate) fn finish(
    a: &Counted,
    b: &[f64],
    x: Vec<f64>,
    status: SolveStatus,
    mon: Monitor,
    opts: &SolverOptions,
    name: &str,
) -> (Vec<f64>, SolveStats) {
    mon.pb.finish_and_clear();
    let mut r = vec![0.0; b.len()];
    op_residual(a, &x, b, &mut r);
    let abs = norm(&r);
    let rel = if mon.bnorm > 0.0 {
        abs / mon.bnorm
    } else {
        abs
    };
    // A recurrence that claimed convergence but whose true residual is above the
    // tolerance is reported as stagnated, with the residual it reached.
    let status = if status == SolveStatus::Converged && rel > opts.tol {
        SolveStatus::Stagnated
    } else {
        status
    };
    let stats = SolveStats {
        solver: name.into(),
        status,
        iterations: mon.ctl.iterations,
        relative_residual: rel,
        absolute_residual: abs,
        rhs_norm: mon.bnorm,
        tolerance: opts.tol,
        history: mon.ctl.history,
        operator_applications: a.count(),
    };
    (x, stats)
}

/// The frame CGLS, LSQR and LSMR share: counts the products with `a`, returns u = 0 for
/// b = 0, else runs `iterate(a, ‖b‖, x, monitor)` from x = 0, and reports the status it
/// returns with the residual recomputed ([`finish`]).
pub(crate) fn run_from_zero(
    a: &dyn LinearOperator,
    b: &[f64],
    opts: &SolverOptions,
    name: &str,
    iterate: impl FnOnce(&Counted, f64, &mut [f64], &mut Monitor) -> SolveStatus,
) -> (Vec<f64>, SolveStats) {
    let counted = Counted::new(a);
    let bnorm = norm(b);
    let mut x = vec![0.0; counted.cols()];
    let noop = |_: usize, _: f64| {};
    let mut mon = monitor(bnorm, opts, &noop);
    let status = if bnorm == 0.0 {
        SolveStatus::Converged
    } else {
        iterate(&counted, bnorm, &mut x, &mut mon)
    };
    finish(&counted, b, x, status, mon, opts, name)
}

/// CGLS on `a u = b` from u = 0, reported as solver `name`.
pub fn cgls(
    a: &dyn LinearOperator,
    b: &[f64],
    opts: &SolverOptions,
    name: &str,
) -> (Vec<f64>, SolveStats) {
    run_from_zero(a, b, opts, name, |a, _bnorm, x, mon| {
        let n = a.cols();
        let mut r = b.to_vec();
        let mut s = vec![0.0; n];
        a.apply_transpose(&r, &mut s);
        let mut p = s.clone();
        let mut gamma = dot(&s, &s);
        let mut q = vec![0.0; a.rows()];
        let mut replacements = 0usize;
        let mut status = SolveStatus::MaxIterations;
        while mon.iterations() < opts.max_iter {
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
            match mon.record(norm(&r)) {
                None => {}
                Some(Outcome::Reached) => {
                    // Confirm with the true residual; restart from it if rounding drifted.
                    op_residual(a, x, b, &mut r);
                    if norm(&r) <= mon.target() {
                        status = SolveStatus::Converged;
                        break;
                    }
                    replacements += 1;
                    if replacements > MAX_REPLACEMENTS {
                        status = SolveStatus::Stagnated;
                        break;
                    }
                    a.apply_transpose(&r, &mut s);
                    p.copy_from_slice(&s);
                    gamma = dot(&s, &s);
                    continue;
                }
                Some(o) => {
                    status = status_of(o);
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
