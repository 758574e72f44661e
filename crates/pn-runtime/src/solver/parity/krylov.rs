//! Preconditioned Krylov methods for the reduced system `S x = f`: CG (symmetric `S`),
//! and for nonsymmetric `S` right-preconditioned restarted GMRES (one application of `S`
//! per iteration, residual norm minimised) or BiCGSTAB (two applications, short recurrences).
//!
//! Both iterate on the true (unpreconditioned) residual `r = f − S x` and stop when
//! `‖r‖₂ ≤ target`, where the caller sets `target = tol·‖b‖₂` of the full system (the
//! reduced residual equals the full one, see `reduced`). They start from the given `x`,
//! so the caller can restart from the true residual if rounding drift leaves the
//! recomputed residual above the tolerance.

use crate::linalg::{axpy, dot, norm, xpby};
use rayon::prelude::*;

/// Which Krylov method ran.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum KrylovMethod {
    /// Preconditioned conjugate gradients.
    Cg,
    /// Right-preconditioned BiCGSTAB.
    BiCgStab,
    /// Right-preconditioned restarted GMRES (restart length [`gmres_restart`]).
    Gmres,
}

impl KrylovMethod {
    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            KrylovMethod::Cg => "cg",
            KrylovMethod::BiCgStab => "bicgstab",
            KrylovMethod::Gmres => "gmres",
        }
    }
}

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

/// Stopping rules and bookkeeping shared by the methods.
pub struct Control<'a> {
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
    /// Applications of `S` so far.
    pub applications: usize,
    /// Relative residual after each iteration.
    pub history: Vec<f64>,
    /// Called with (iteration, relative residual) for progress display.
    pub progress: &'a dyn Fn(usize, f64),
    best: f64,
    best_at: usize,
}

impl<'a> Control<'a> {
    /// The controller for a system whose right-hand side has norm `bnorm`, with the limits of
    /// `opts`: target `tol·‖b‖`, residuals recorded relative to `‖b‖` (to 1 when `b = 0`).
    pub fn for_options(
        opts: &crate::solver::SolverOptions,
        bnorm: f64,
        progress: &'a dyn Fn(usize, f64),
    ) -> Self {
        Self::new(
            opts.tol * bnorm,
            if bnorm > 0.0 { bnorm } else { 1.0 },
            opts.max_iter,
            opts.stagnation_window,
            opts.stagnation_drop,
            opts.divergence_limit,
            progress,
        )
    }

    /// A controller with the given limits.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        target: f64,
        scale: f64,
        max_iter: usize,
        stagnation_window: usize,
        stagnation_drop: f64,
        divergence_limit: f64,
        progress: &'a dyn Fn(usize, f64),
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
            progress,
            best: f64::INFINITY,
            best_at: 0,
        }
    }

    /// `Some` when a run (or restart) whose starting residual has norm `rnorm` must not
    /// iterate: the residual already meets the target, or the iteration budget is spent.
    fn before_start(&self, rnorm: f64) -> Option<Outcome> {
        if rnorm <= self.target {
            return Some(Outcome::Reached);
        }
        if self.iterations >= self.max_iter {
            return Some(Outcome::MaxIterations);
        }
        None
    }

    /// Records one iteration's residual norm; `Some` when the run must stop.
    pub(crate) fn record(&mut self, rnorm: f64) -> Option<Outcome> {
        self.iterations += 1;
        let rel = rnorm / self.scale;
        self.history.push(rel);
        (self.progress)(self.iterations, rel);
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
}

/// The true residual `r = f − S x` (one application of `S`, counted in `ctl`).
fn true_residual(
    apply: &dyn Fn(&[f64], &mut [f64]),
    f: &[f64],
    x: &[f64],
    r: &mut [f64],
    ctl: &mut Control,
) {
    apply(x, r);
    ctl.applications += 1;
    r.iter_mut().zip(f).for_each(|(ri, fi)| *ri = fi - *ri);
}

/// `y = x − alpha v` into `out`.
fn sub_scaled(x: &[f64], alpha: f64, v: &[f64], out: &mut [f64]) {
    out.par_iter_mut()
        .zip(x.par_iter().zip(v.par_iter()))
        .for_each(|(o, (a, b))| *o = a - alpha * b);
}

/// Preconditioned CG for symmetric positive definite `S`, starting from `x`.
pub fn pcg(
    apply: &dyn Fn(&[f64], &mut [f64]),
    precond: &dyn Fn(&[f64], &mut [f64]),
    f: &[f64],
    x: &mut [f64],
    ctl: &mut Control,
) -> Outcome {
    let n = f.len();
    let mut r = vec![0.0; n];
    true_residual(apply, f, x, &mut r, ctl);
    if let Some(o) = ctl.before_start(norm(&r)) {
        return o;
    }
    let mut z = vec![0.0; n];
    precond(&r, &mut z);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut q = vec![0.0; n];
    loop {
        apply(&p, &mut q);
        ctl.applications += 1;
        let pq = dot(&p, &q);
        if pq <= 0.0 || !pq.is_finite() || rz == 0.0 {
            // S (or M) is not positive definite along p, or an exact zero residual.
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
        precond(&r, &mut z);
        let rz_new = dot(&r, &z);
        let beta = rz_new / rz;
        rz = rz_new;
        xpby(&z, beta, &mut p);
    }
}

/// Right-preconditioned BiCGSTAB for nonsymmetric `S`, starting from `x`.
pub fn bicgstab(
    apply: &dyn Fn(&[f64], &mut [f64]),
    precond: &dyn Fn(&[f64], &mut [f64]),
    f: &[f64],
    x: &mut [f64],
    ctl: &mut Control,
) -> Outcome {
    let n = f.len();
    let mut r = vec![0.0; n];
    true_residual(apply, f, x, &mut r, ctl);
    if let Some(o) = ctl.before_start(norm(&r)) {
        return o;
    }
    let r_hat = r.clone();
    let (mut rho, mut alpha, mut omega) = (1.0f64, 1.0f64, 1.0f64);
    let mut v = vec![0.0; n];
    let mut p = vec![0.0; n];
    let mut p_hat = vec![0.0; n];
    let mut s = vec![0.0; n];
    let mut s_hat = vec![0.0; n];
    let mut t = vec![0.0; n];
    loop {
        let rho_new = dot(&r_hat, &r);
        if rho_new == 0.0 || !rho_new.is_finite() {
            return Outcome::Stagnated; // breakdown: the caller restarts from the true residual
        }
        let beta = (rho_new / rho) * (alpha / omega);
        rho = rho_new;
        // p = r + β (p − ω v)
        p.par_iter_mut()
            .zip(r.par_iter().zip(v.par_iter()))
            .for_each(|(pi, (ri, vi))| *pi = ri + beta * (*pi - omega * vi));
        precond(&p, &mut p_hat);
        apply(&p_hat, &mut v);
        ctl.applications += 1;
        let rv = dot(&r_hat, &v);
        if rv == 0.0 || !rv.is_finite() {
            return Outcome::Stagnated;
        }
        alpha = rho / rv;
        sub_scaled(&r, alpha, &v, &mut s);
        let snorm = norm(&s);
        if snorm <= ctl.target {
            axpy(alpha, &p_hat, x);
            r.copy_from_slice(&s);
            return ctl.record(snorm).unwrap_or(Outcome::Reached);
        }
        precond(&s, &mut s_hat);
        apply(&s_hat, &mut t);
        ctl.applications += 1;
        let tt = dot(&t, &t);
        if tt == 0.0 {
            return Outcome::Stagnated;
        }
        omega = dot(&t, &s) / tt;
        x.par_iter_mut()
            .zip(p_hat.par_iter().zip(s_hat.par_iter()))
            .for_each(|(xi, (pi, si))| *xi += alpha * pi + omega * si);
        sub_scaled(&s, omega, &t, &mut r);
        if let Some(o) = ctl.record(norm(&r)) {
            return o;
        }
        if omega == 0.0 {
            return Outcome::Stagnated;
        }
    }
}

/// GMRES restart length for `n` unknowns: the Krylov basis holds `m + 1` vectors, so `m`
/// shrinks for large systems to keep it within ~400 MB (at least 20); at most 30, beyond
/// which the orthogonalisation costs more than the saved iterations (measured on the
/// checkerboard P_3/P_5).
pub fn gmres_restart(n: usize) -> usize {
    let budget = 400_000_000 / (8 * n.max(1));
    budget.clamp(20, 30)
}

/// Right-preconditioned restarted GMRES (modified Gram–Schmidt, Givens rotations), starting
/// from `x`. With right preconditioning the minimised quantity is the true residual
/// `‖f − S x‖₂`, so the recorded history is that of the unpreconditioned system.
pub fn gmres(
    apply: &dyn Fn(&[f64], &mut [f64]),
    precond: &dyn Fn(&[f64], &mut [f64]),
    f: &[f64],
    x: &mut [f64],
    ctl: &mut Control,
) -> Outcome {
    let n = f.len();
    let m = gmres_restart(n);
    let mut r = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(m + 1);
    // Hessenberg matrix column by column: h[j] has j + 2 entries.
    let mut h: Vec<Vec<f64>> = Vec::with_capacity(m);
    let (mut cs, mut sn, mut g) = (vec![0.0; m], vec![0.0; m], vec![0.0; m + 1]);
    loop {
        true_residual(apply, f, x, &mut r, ctl);
        let beta = norm(&r);
        if let Some(o) = ctl.before_start(beta) {
            return o;
        }
        basis.clear();
        h.clear();
        g.iter_mut().for_each(|v| *v = 0.0);
        g[0] = beta;
        basis.push(r.iter().map(|v| v / beta).collect());
        let mut outcome = None;
        let mut k = 0;
        while k < m {
            precond(&basis[k], &mut z);
            apply(&z, &mut w);
            ctl.applications += 1;
            let mut col = vec![0.0; k + 2];
            for (i, v) in basis.iter().enumerate() {
                let hij = dot(&w, v);
                col[i] = hij;
                axpy(-hij, v, &mut w);
            }
            let wn = norm(&w);
            col[k + 1] = wn;
            for i in 0..k {
                let (a, b) = (col[i], col[i + 1]);
                col[i] = cs[i] * a + sn[i] * b;
                col[i + 1] = -sn[i] * a + cs[i] * b;
            }
            let (a, b) = (col[k], col[k + 1]);
            let rho = a.hypot(b);
            if rho == 0.0 {
                outcome = Some(Outcome::Stagnated);
                break;
            }
            cs[k] = a / rho;
            sn[k] = b / rho;
            col[k] = rho;
            col[k + 1] = 0.0;
            g[k + 1] = -sn[k] * g[k];
            g[k] *= cs[k];
            h.push(col);
            k += 1;
            if let Some(o) = ctl.record(g[k].abs()) {
                outcome = Some(o);
                break;
            }
            if wn == 0.0 {
                break; // lucky breakdown: the solution lies in the current space
            }
            basis.push(w.iter().map(|v| v / wn).collect());
        }
        // x += M⁻¹ V y with H y = g (upper triangular after the rotations).
        let mut y = vec![0.0; k];
        for i in (0..k).rev() {
            let mut s = g[i];
            for j in i + 1..k {
                s -= h[j][i] * y[j];
            }
            y[i] = s / h[i][i];
        }
        w.iter_mut().for_each(|v| *v = 0.0);
        for (v, yi) in basis.iter().zip(&y) {
            axpy(*yi, v, &mut w);
        }
        precond(&w, &mut z);
        axpy(1.0, &z, x);
        match outcome {
            // The rotated residual estimate drifts from the true one: a restart recomputes it.
            Some(Outcome::Reached) => {
                true_residual(apply, f, x, &mut r, ctl);
                if norm(&r) <= ctl.target {
                    return Outcome::Reached;
                }
            }
            Some(o) => return o,
            None => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tridiag(n: usize, lower: f64, diag: f64, upper: f64) -> impl Fn(&[f64], &mut [f64]) {
        move |x: &[f64], y: &mut [f64]| {
            for i in 0..n {
                let mut s = diag * x[i];
                if i > 0 {
                    s += lower * x[i - 1];
                }
                if i + 1 < n {
                    s += upper * x[i + 1];
                }
                y[i] = s;
            }
        }
    }

    fn check(method: KrylovMethod, lower: f64, upper: f64) {
        let n = 50;
        let op = tridiag(n, lower, 3.0, upper);
        let want: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut f = vec![0.0; n];
        op(&want, &mut f);
        let id = |r: &[f64], z: &mut [f64]| z.copy_from_slice(r);
        let noop = |_: usize, _: f64| {};
        let target = 1e-12 * norm(&f);
        let mut ctl = Control::new(target, norm(&f), 1000, 100, 1e-4, 1e8, &noop);
        let mut x = vec![0.0; n];
        let out = match method {
            KrylovMethod::Cg => pcg(&op, &id, &f, &mut x, &mut ctl),
            KrylovMethod::BiCgStab => bicgstab(&op, &id, &f, &mut x, &mut ctl),
            KrylovMethod::Gmres => gmres(&op, &id, &f, &mut x, &mut ctl),
        };
        assert_eq!(out, Outcome::Reached);
        // ‖x − x*‖ ≤ ‖S⁻¹‖ ‖r‖ with ‖S⁻¹‖ ≤ 1 (diagonally dominant by ≥ 1).
        let err = x
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-10, "{method:?}: error {err:e}");
        assert!(ctl.applications > 0 && ctl.iterations == ctl.history.len());
    }

    #[test]
    fn cg_solves_spd() {
        check(KrylovMethod::Cg, -1.0, -1.0);
    }

    #[test]
    fn bicgstab_solves_nonsymmetric() {
        check(KrylovMethod::BiCgStab, -1.5, 0.5);
    }

    #[test]
    fn gmres_solves_nonsymmetric() {
        check(KrylovMethod::Gmres, -1.5, 0.5);
    }
}
