//! The one stopping controller of every iterative method ([`Control`]), and the frame the
//! least-squares methods share (`run_from_zero`).
//!
//! A method reports the norm of its residual (recurrence or true) after each iteration to
//! [`Control::record`], which stops it on
//! * the target `tol·‖b‖₂` (the caller confirms it on the recomputed residual, see
//!   [`Control::confirm`] and [`Control::may_restart`]),
//! * the iteration budget (counted over restarts),
//! * stagnation: the best relative residual has not dropped by a factor
//!   `1 − stagnation_drop` within `stagnation_window` iterations,
//! * divergence: a relative residual above `divergence_limit`, or not finite,
//!
//! and keeps the history; the optional [`crate::IterationObserver`] of the stopping rules
//! hears of every iteration and of the end (the methods never print).

use crate::linalg::norm;
use crate::operator::{op_residual, Counted, LinearOperator};
use crate::stats::{SolveStats, SolveStatus, Stopping};
use rayon::prelude::*;

/// How many times a method may restart from (or re-check against) the true residual after
/// its recurrence met the target while the recomputed residual did not.
pub const MAX_RESTARTS: usize = 3;

/// How a Krylov run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// `‖r‖ ≤ target`.
    Reached,
    /// Iteration budget spent.
    MaxIterations,
    /// No progress within the stagnation window, or a breakdown.
    Stagnated,
    /// Residual not finite or above the divergence limit.
    Diverged,
}

impl Outcome {
    /// The reported status of a run that ended so (the residual not re-checked).
    pub fn status(self) -> SolveStatus {
        match self {
            Outcome::Reached => SolveStatus::Converged,
            Outcome::MaxIterations => SolveStatus::MaxIterations,
            Outcome::Stagnated => SolveStatus::Stagnated,
            Outcome::Diverged => SolveStatus::Diverged,
        }
    }
}

/// Stopping rules, history and progress of one solve (over all its restarts).
pub struct Control {
    /// Absolute residual target.
    pub target: f64,
    /// Residuals are divided by this for the history (‖b‖ of the full system).
    pub scale: f64,
    /// Total iteration budget (over restarts).
    pub max_iter: usize,
    /// Stagnation window (iterations).
    pub stagnation_window: usize,
    /// Required relative drop within the window.
    pub stagnation_drop: f64,
    /// Divergence limit on the relative residual.
    pub divergence_limit: f64,
    /// Iterations done so far.
    pub iterations: usize,
    /// Operator applications counted by the methods (true residuals and Krylov products).
    pub applications: usize,
    /// Relative residual after each iteration.
    pub history: Vec<f64>,
    /// Restarts (or re-checks) taken so far ([`Control::may_restart`]).
    pub restarts: usize,
    observer: Option<crate::stats::IterationObserver>,
    best: f64,
    best_at: usize,
    /// [`Control::confirm`]: the estimate at which the true residual is next checked.
    check_below: f64,
}

impl Control {
    /// The controller for a system whose right-hand side has norm `bnorm`, with the limits of
    /// `opts`: target `tol·‖b‖`, residuals recorded relative to `‖b‖` (to 1 when `b = 0`),
    /// reported to `opts.observer`.
    pub fn for_options(opts: &Stopping, bnorm: f64) -> Self {
        let mut c = Self::new(
            opts.tol * bnorm,
            if bnorm > 0.0 { bnorm } else { 1.0 },
            opts.max_iter,
            opts.stagnation_window,
            opts.stagnation_drop,
            opts.divergence_limit,
        );
        c.observer = opts.observer.clone();
        c
    }

    /// A controller with the given limits and no progress display.
    pub fn new(
        target: f64,
        scale: f64,
        max_iter: usize,
        stagnation_window: usize,
        stagnation_drop: f64,
        divergence_limit: f64,
    ) -> Self {
        Self {
            target,
            scale,
            max_iter,
            stagnation_window,
            stagnation_drop,
            divergence_limit,
            iterations: 0,
            applications: 0,
            history: Vec::new(),
            restarts: 0,
            observer: None,
            best: f64::INFINITY,
            best_at: 0,
            check_below: target,
        }
    }

    /// `Some` when a run (or restart) whose starting residual has norm `rnorm` must not
    /// iterate: the residual already meets the target, or the iteration budget is spent.
    pub fn before_start(&self, rnorm: f64) -> Option<Outcome> {
        if rnorm <= self.target {
            return Some(Outcome::Reached);
        }
        if self.iterations >= self.max_iter {
            return Some(Outcome::MaxIterations);
        }
        None
    }

    /// Records one iteration's residual norm; `Some` when the run must stop.
    pub fn record(&mut self, rnorm: f64) -> Option<Outcome> {
        self.iterations += 1;
        let rel = rnorm / self.scale;
        self.history.push(rel);
        if let Some(o) = &self.observer {
            o.notify(self.iterations, rel);
        }
        if !rel.is_finite() || rel > self.divergence_limit {
            return Some(Outcome::Diverged);
        }
        if rnorm <= self.target {
            return Some(Outcome::Reached);
        }
        if rel < self.best * (1.0 - self.stagnation_drop) {
            self.best = rel;
            self.best_at = self.iterations;
        } else if self.iterations - self.best_at >= self.stagnation_window {
            return Some(Outcome::Stagnated);
        }
        if self.iterations >= self.max_iter {
            return Some(Outcome::MaxIterations);
        }
        None
    }

    /// Counts one restart from the true residual; `false` when [`MAX_RESTARTS`] are spent.
    pub fn may_restart(&mut self) -> bool {
        if self.restarts >= MAX_RESTARTS {
            return false;
        }
        self.restarts += 1;
        true
    }

    /// For methods that iterate on without restarting (LSQR, LSMR): with the recurrence
    /// estimate `est` at or below the target, checks the true residual `true_norm()` once
    /// the estimate has fallen to the next check level (first the target, then half the
    /// estimate of the last failed check). `None`: iterate on; `Some(Reached)` when the
    /// true residual meets the target, `Some(Stagnated)` after [`MAX_RESTARTS`] failed
    /// checks.
    pub fn confirm(&mut self, est: f64, true_norm: impl FnOnce() -> f64) -> Option<Outcome> {
        if est > self.check_below {
            return None;
        }
        if true_norm() <= self.target {
            return Some(Outcome::Reached);
        }
        if !self.may_restart() {
            return Some(Outcome::Stagnated);
        }
        self.check_below = est * 0.5;
        None
    }

    /// Tells the observer that the iterations have ended.
    pub fn finish(&self) {
        if let Some(o) = &self.observer {
            o.finish();
        }
    }
}

/// The true residual `r = f − A x` (one application of `A`, counted in `ctl`; none when `x`
/// is zero).
pub fn true_residual(
    a: &dyn LinearOperator,
    f: &[f64],
    x: &[f64],
    r: &mut [f64],
    ctl: &mut Control,
) {
    // From a zero guess `A x = 0`: the residual is `f`, without an application of `A`.
    if x.par_iter().all(|&v| v == 0.0) {
        r.copy_from_slice(f);
        return;
    }
    op_residual(a, x, f, r);
    ctl.applications += 1;
}

/// The frame CGLS, LSQR and LSMR share: counts the products with `a`, returns u = 0 for
/// b = 0, else runs `iterate(a, ‖b‖, x, control)` from x = 0, and reports the status it
/// returns with the residual recomputed from `x`. A recurrence that claimed convergence
/// but whose true residual is above the tolerance is reported as stagnated.
pub fn run_from_zero(
    a: &dyn LinearOperator,
    b: &[f64],
    opts: &Stopping,
    name: &str,
    iterate: impl FnOnce(&Counted, f64, &mut [f64], &mut Control) -> SolveStatus,
) -> (Vec<f64>, SolveStats) {
    let counted = Counted::new(a);
    let bnorm = norm(b);
    let mut x = vec![0.0; counted.cols()];
    let mut ctl = Control::for_options(opts, bnorm);
    let status = if bnorm == 0.0 {
        SolveStatus::Converged
    } else {
        iterate(&counted, bnorm, &mut x, &mut ctl)
    };
    ctl.finish();
    let mut r = vec![0.0; b.len()];
    op_residual(&counted, &x, b, &mut r);
    let abs = norm(&r);
    let rel = if bnorm > 0.0 { abs / bnorm } else { abs };
    let status = if status == SolveStatus::Converged && rel > opts.tol {
        SolveStatus::Stagnated
    } else {
        status
    };
    let stats = SolveStats {
        solver: name.into(),
        status,
        iterations: ctl.iterations,
        relative_residual: rel,
        absolute_residual: abs,
        rhs_norm: bnorm,
        tolerance: opts.tol,
        history: ctl.history,
        operator_applications: counted.count(),
        notes: Vec::new(),
    };
    (x, stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stops_on_target_stagnation_divergence_and_budget() {
        let mut c = Control::new(1e-3, 1.0, 100, 3, 0.5, 1e3);
        assert_eq!(c.before_start(1e-4), Some(Outcome::Reached));
        assert_eq!(c.record(0.5), None);
        assert_eq!(c.record(1e-4), Some(Outcome::Reached));
        let mut c = Control::new(0.0, 1.0, 100, 3, 0.5, 1e3);
        assert_eq!(c.record(1.0), None);
        assert_eq!(c.record(0.9), None);
        assert_eq!(c.record(0.8), None);
        assert_eq!(c.record(0.7), Some(Outcome::Stagnated));
        let mut c = Control::new(0.0, 1.0, 100, 3, 0.5, 1e3);
        assert_eq!(c.record(f64::NAN), Some(Outcome::Diverged));
        let mut c = Control::new(0.0, 1.0, 2, 10, 0.5, 1e3);
        assert_eq!(c.record(1.0), None);
        assert_eq!(c.record(0.1), Some(Outcome::MaxIterations));
        assert_eq!(c.history, vec![1.0, 0.1]);
    }

    #[test]
    fn confirm_rechecks_at_halved_estimates() {
        let mut c = Control::new(1.0, 1.0, 100, 10, 0.5, 1e3);
        // The true residual stays above the target: checks at 1.0, 0.4, 0.1, then give up.
        assert_eq!(c.confirm(1.0, || 2.0), None);
        assert_eq!(c.confirm(0.6, || 2.0), None); // not due: 0.6 > 0.5
        assert_eq!(c.confirm(0.4, || 2.0), None);
        assert_eq!(c.confirm(0.1, || 2.0), None);
        assert_eq!(c.confirm(0.05, || 2.0), Some(Outcome::Stagnated));
        let mut c = Control::new(1.0, 1.0, 100, 10, 0.5, 1e3);
        assert_eq!(c.confirm(1.0, || 0.5), Some(Outcome::Reached));
    }
}
