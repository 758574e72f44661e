//! LSQR (Paige & Saunders 1982, ACM TOMS 8:43–71): Golub–Kahan bidiagonalisation of `A`
//! with a QR update, mathematically equivalent to CGLS but numerically better behaved on
//! ill-conditioned systems. Runs on any [`LinearOperator`] (assembled: `--solver lsqr`,
//! matrix-free: `--solver lsqr-mf`).
//!
//! The recurrence gives ‖b − A u_k‖₂ = φ̄_k for free; the solver stops when φ̄_k/‖b‖₂ ≤ tol,
//! then recomputes the true residual. If rounding drift left it above the tolerance it
//! iterates on and re-checks each time φ̄ has fallen by another factor 2 (at most
//! [`crate::control::MAX_RESTARTS`] re-checks, then "stagnated" with the residual reached;
//! [`crate::control::Control::confirm`]). No damping, no parameters beyond the controller's; the info is
//! [`SolveStats`].

use crate::control::{run_from_zero, Outcome};
use crate::linalg::{axpy, norm, xpby};
use crate::operator::{op_residual, LinearOperator};
use crate::stats::{SolveStats, SolveStatus, Stopping};
use rayon::prelude::*;

/// `v ← (w − c·v)`, returning ‖v‖ (the bidiagonalisation step `β u = A v − α u`).
pub(crate) fn bidiag_step(w: &[f64], c: f64, v: &mut [f64]) -> f64 {
    v.par_iter_mut()
        .zip(w)
        .for_each(|(vi, wi)| *vi = wi - c * *vi);
    norm(v)
}

/// The start of the Golub–Kahan bidiagonalisation shared by LSQR and LSMR:
/// β₁u₁ = b (β₁ = `bnorm`), α₁v₁ = Aᵀu₁; returns (u₁, v₁, α₁).
pub(crate) fn golub_kahan_start(
    a: &dyn LinearOperator,
    b: &[f64],
    bnorm: f64,
) -> (Vec<f64>, Vec<f64>, f64) {
    let mut u = b.to_vec();
    scale_inv(&mut u, bnorm);
    let mut v = vec![0.0; a.cols()];
    a.apply_transpose(&u, &mut v);
    let alpha = norm(&v);
    scale_inv(&mut v, alpha);
    (u, v, alpha)
}

/// `v ← v / s` when `s > 0`.
pub(crate) fn scale_inv(v: &mut [f64], s: f64) {
    if s > 0.0 {
        let inv = 1.0 / s;
        v.par_iter_mut().for_each(|x| *x *= inv);
    }
}

/// `‖b − A x‖₂`, with `r` as work space.
pub(crate) fn true_residual_norm(
    a: &dyn LinearOperator,
    x: &[f64],
    b: &[f64],
    r: &mut [f64],
) -> f64 {
    op_residual(a, x, b, r);
    norm(r)
}

/// LSQR on `a u = b` from u = 0 (no damping), reported as solver `name`.
pub fn lsqr(
    a: &dyn LinearOperator,
    b: &[f64],
    opts: &Stopping,
    name: &str,
) -> (Vec<f64>, SolveStats) {
    run_from_zero(a, b, opts, name, |a, bnorm, x, ctl| {
        let (m, n) = (a.rows(), a.cols());
        let (mut u, mut v, mut alpha) = golub_kahan_start(a, b, bnorm);
        let mut w = v.clone();
        let mut phibar = bnorm;
        let mut rhobar = alpha;
        let mut av = vec![0.0; m];
        let mut atu = vec![0.0; n];
        let mut r = vec![0.0; m];
        let mut status = SolveStatus::MaxIterations;
        while ctl.iterations < opts.max_iter {
            if alpha == 0.0 {
                // Aᵀr = 0: the least-squares minimum is reached (b − Au ≠ 0 unless converged).
                status = SolveStatus::Stagnated;
                break;
            }
            // β u = A v − α u;  α v = Aᵀu − β v.
            a.apply(&v, &mut av);
            let beta = bidiag_step(&av, alpha, &mut u);
            scale_inv(&mut u, beta);
            a.apply_transpose(&u, &mut atu);
            alpha = bidiag_step(&atu, beta, &mut v);
            scale_inv(&mut v, alpha);
            // Plane rotation eliminating β.
            let rho = rhobar.hypot(beta);
            let (c, s) = (rhobar / rho, beta / rho);
            let theta = s * alpha;
            rhobar = -c * alpha;
            let phi = c * phibar;
            phibar *= s;
            axpy(phi / rho, &w, x);
            // w = v − (θ/ρ) w.
            xpby(&v, -theta / rho, &mut w);
            let est = phibar.abs();
            let stop = match ctl.record(est) {
                Some(Outcome::Reached) => ctl.confirm(est, || true_residual_norm(a, x, b, &mut r)),
                o => o,
            };
            if let Some(o) = stop {
                status = o.status();
                break;
            }
        }
        status
    })
}
