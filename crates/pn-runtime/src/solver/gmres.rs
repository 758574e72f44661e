//! Right-preconditioned restarted GMRES (Saad & Schultz 1986) for nonsymmetric operators:
//! one application of the operator and of the preconditioner per iteration, the residual
//! norm minimised over the Krylov space, at the price of an orthogonalisation against the
//! whole basis (modified Gram–Schmidt, Givens rotations).
//!
//! With right preconditioning the minimised quantity is the true residual `‖f − A x‖₂`,
//! so the history recorded in [`Control`] is that of the unpreconditioned system. The only
//! parameter is the restart length ([`GmresParams`]).

use super::control::{true_residual, Control, Outcome};
use crate::linalg::{axpy, dot, norm};
use crate::operator::{LinearOperator, Preconditioner};

/// Parameters of [`gmres_with`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GmresParams {
    /// Krylov vectors per cycle before a restart (the basis holds `restart + 1` vectors).
    pub restart: usize,
}

impl GmresParams {
    /// The default for `n` unknowns: restart length [`gmres_restart`]`(n)`.
    pub fn for_len(n: usize) -> Self {
        Self {
            restart: gmres_restart(n),
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

/// GMRES on `a x = f` from `x` with the preconditioner `m` and the default parameters
/// ([`GmresParams::for_len`]).
pub fn gmres(
    a: &dyn LinearOperator,
    m: &dyn Preconditioner,
    f: &[f64],
    x: &mut [f64],
    ctl: &mut Control,
) -> Outcome {
    gmres_with(&GmresParams::for_len(f.len()), a, m, f, x, ctl)
}

/// GMRES on `a x = f` from `x` with the preconditioner `m` and the parameters `params`.
pub fn gmres_with(
    params: &GmresParams,
    a: &dyn LinearOperator,
    precond: &dyn Preconditioner,
    f: &[f64],
    x: &mut [f64],
    ctl: &mut Control,
) -> Outcome {
    let n = f.len();
    let m = params.restart.max(1);
    let mut r = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(m + 1);
    // Hessenberg matrix column by column: h[j] has j + 2 entries.
    let mut h: Vec<Vec<f64>> = Vec::with_capacity(m);
    let (mut cs, mut sn, mut g) = (vec![0.0; m], vec![0.0; m], vec![0.0; m + 1]);
    loop {
        true_residual(a, f, x, &mut r, ctl);
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
            precond.apply(&basis[k], &mut z);
            a.apply(&z, &mut w);
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
        precond.apply(&w, &mut z);
        axpy(1.0, &z, x);
        match outcome {
            // The rotated residual estimate drifts from the true one: a restart recomputes it.
            Some(Outcome::Reached) => {
                true_residual(a, f, x, &mut r, ctl);
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

    #[test]
    fn gmres_solves_nonsymmetric() {
        let id = crate::operator::Identity;
        super::super::cg::tests::check(|a, x, f, ctl| gmres(a, &id, f, x, ctl), -1.5, 0.5);
        // A short restart still converges (more cycles).
        let p = GmresParams { restart: 3 };
        super::super::cg::tests::check(|a, x, f, ctl| gmres_with(&p, a, &id, f, x, ctl), -1.5, 0.5);
    }
}
