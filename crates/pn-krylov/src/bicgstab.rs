//! Right-preconditioned BiCGSTAB (van der Vorst 1992) for nonsymmetric operators: two
//! applications of the operator and of the preconditioner per iteration, short
//! recurrences.
//!
//! Iterates on the true residual and stops when `‖r‖₂ ≤ target` ([`Control`]); a
//! breakdown (`ρ = 0`, `r̂ᵀv = 0`, `ω = 0`) ends the run as [`Outcome::Stagnated`] so that
//! the caller can restart from the true residual. No parameters beyond the controller's.

use crate::control::{true_residual, Control, Outcome};
use crate::linalg::{axpy, dot, norm};
use crate::operator::{LinearOperator, Preconditioner};
use rayon::prelude::*;

/// `out = x − alpha v`.
fn sub_scaled(x: &[f64], alpha: f64, v: &[f64], out: &mut [f64]) {
    out.par_iter_mut()
        .zip(x.par_iter().zip(v.par_iter()))
        .for_each(|(o, (a, b))| *o = a - alpha * b);
}

/// Right-preconditioned BiCGSTAB on `a x = f` from `x` with the preconditioner `m`.
pub fn bicgstab(
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
        m.apply(&p, &mut p_hat);
        a.apply(&p_hat, &mut v);
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
        m.apply(&s, &mut s_hat);
        a.apply(&s_hat, &mut t);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bicgstab_solves_nonsymmetric() {
        let id = crate::operator::Identity;
        crate::cg::tests::check(|a, x, f, ctl| bicgstab(a, &id, f, x, ctl), -1.5, 0.5);
    }
}
