//! LSMR (Fong & Saunders 2011, SIAM J. Sci. Comput. 33:2950–2971): the same Golub–Kahan
//! bidiagonalisation as LSQR, but minimising ‖Aᵀr_k‖ (MINRES on the normal equations), so
//! ‖Aᵀr‖ decreases monotonically as well as ‖r‖. Runs on any [`LinearOperator`]
//! (`--solver lsmr`, `--solver lsmr-mf`).
//!
//! ‖r_k‖ is estimated by the paper's recurrence (§3.3, without damping); the solver stops when
//! the estimate over ‖b‖₂ is ≤ tol and the recomputed true residual confirms it (re-checks
//! as in [`super::lsqr`], [`crate::control::Control::confirm`]). No damping, no parameters
//! beyond the controller's; the info is [`SolveStats`].

use crate::control::{run_from_zero, Outcome};
use crate::linalg::{axpy, xpby};
use crate::lsqr::{bidiag_step, golub_kahan_start, scale_inv, true_residual_norm};
use crate::operator::LinearOperator;
use crate::stats::{SolveStats, SolveStatus, Stopping};

/// `(c, s, r)` with `r = √(a² + b²)`, `c = a/r`, `s = b/r` (a Givens rotation).
fn sym_ortho(a: f64, b: f64) -> (f64, f64, f64) {
    let r = a.hypot(b);
    if r == 0.0 {
        (1.0, 0.0, 0.0)
    } else {
        (a / r, b / r, r)
    }
}

/// LSMR on `a u = b` from u = 0 (no damping), reported as solver `name`.
pub fn lsmr(
    a: &dyn LinearOperator,
    b: &[f64],
    opts: &Stopping,
    name: &str,
) -> (Vec<f64>, SolveStats) {
    run_from_zero(a, b, opts, name, |a, bnorm, x, ctl| {
        let (m, n) = (a.rows(), a.cols());
        let (mut u, mut v, mut alpha) = golub_kahan_start(a, b, bnorm);

        // Variables of the two QR factorisations (names as in the paper and SciPy's lsmr).
        let mut zetabar = alpha * bnorm;
        let mut alphabar = alpha;
        let (mut rho, mut rhobar, mut cbar, mut sbar) = (1.0f64, 1.0f64, 1.0f64, 0.0f64);
        let mut h = v.clone();
        let mut hbar = vec![0.0; n];
        // ‖r‖ estimation.
        let mut betadd = bnorm;
        let mut betad = 0.0f64;
        let mut rhodold = 1.0f64;
        let mut tautildeold = 0.0f64;
        let mut thetatilde = 0.0f64;
        let mut zeta = 0.0f64;

        let mut av = vec![0.0; m];
        let mut atu = vec![0.0; n];
        let mut r = vec![0.0; m];
        let mut status = SolveStatus::MaxIterations;
        while ctl.iterations < opts.max_iter {
            if alpha == 0.0 {
                status = SolveStatus::Stagnated;
                break;
            }
            a.apply(&v, &mut av);
            let beta = bidiag_step(&av, alpha, &mut u);
            scale_inv(&mut u, beta);
            a.apply_transpose(&u, &mut atu);
            alpha = bidiag_step(&atu, beta, &mut v);
            scale_inv(&mut v, alpha);

            // First rotation (no damping: α̂ = ᾱ).
            let rhoold = rho;
            let (c, s, rho_new) = sym_ortho(alphabar, beta);
            rho = rho_new;
            let thetanew = s * alpha;
            alphabar = c * alpha;
            // Second rotation.
            let rhobarold = rhobar;
            let zetaold = zeta;
            let thetabar = sbar * rho;
            let (cb, sb, rb) = sym_ortho(cbar * rho, thetanew);
            cbar = cb;
            sbar = sb;
            rhobar = rb;
            zeta = cbar * zetabar;
            zetabar *= -sbar;
            // h̄ = h − (θ̄ρ/(ρ_old ρ̄_old)) h̄;  x += ζ/(ρ ρ̄) h̄;  h = v − (θ/ρ) h.
            xpby(&h, -(thetabar * rho / (rhoold * rhobarold)), &mut hbar);
            axpy(zeta / (rho * rhobar), &hbar, x);
            xpby(&v, -(thetanew / rho), &mut h);

            // ‖r‖ estimate.
            let betaacute = betadd;
            let betahat = c * betaacute;
            betadd = -s * betaacute;
            let thetatildeold = thetatilde;
            let (ctildeold, stildeold, rhotildeold) = sym_ortho(rhodold, thetabar);
            thetatilde = stildeold * rhobar;
            rhodold = ctildeold * rhobar;
            betad = -stildeold * betad + ctildeold * betahat;
            tautildeold = (zetaold - thetatildeold * tautildeold) / rhotildeold;
            let taud = (zeta - thetatilde * tautildeold) / rhodold;
            let normr = ((betad - taud).powi(2) + betadd * betadd).sqrt();

            let stop = match ctl.record(normr) {
                Some(Outcome::Reached) => {
                    ctl.confirm(normr, || true_residual_norm(a, x, b, &mut r))
                }
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
