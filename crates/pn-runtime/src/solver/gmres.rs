//! Right-preconditioned restarted GMRES (Saad & Schultz 1986) for nonsymmetric operators:
//! one application of the operator and of the preconditioner per iteration, the residual
//! norm minimised over the Krylov space, at the price of an orthogonalisation against the
//! whole basis (modified Gram–Schmidt, Givens rotations).
//!
//! With right preconditioning the minimised quantity is the true residual `‖f − A x‖₂`,
//! so the history recorded in [`Control`] is that of the unpreconditioned system. The
//! parameters are the restart length and the precision of the stored basis
//! ([`GmresParams`]).
//!
//! **Single-precision basis.** On large systems solved to a modest tolerance the basis is
//! stored in `f32` ([`GmresParams::f32_basis`]): half the memory of the largest array of the
//! solve (the 80³ P_5 point source: 19 vectors of 7.8 M unknowns, 1.2 GB in `f64`) and half
//! the traffic of the orthogonalisation. Products, projections and the update of `x` are
//! accumulated in `f64`; only the stored directions are rounded (relative 6e-8), which
//! perturbs the Krylov space, not the answer's check: the method's residual estimate is
//! confirmed with the true `f64` residual before the solve reports convergence, and the
//! caller continues from there if it is not met.

use super::control::{true_residual, Control, Outcome};
use crate::linalg::{axpy, dot, norm};
use crate::operator::{LinearOperator, Preconditioner};
use rayon::prelude::*;

/// Parameters of [`gmres_with`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GmresParams {
    /// Krylov vectors per cycle before a restart (the basis holds `restart + 1` vectors).
    pub restart: usize,
    /// Store the basis in `f32` (module docs).
    pub f32_basis: bool,
}

impl GmresParams {
    /// The default for `n` unknowns: restart length [`gmres_restart`]`(n)`, a `f64` basis.
    pub fn for_len(n: usize) -> Self {
        Self {
            restart: gmres_restart(n),
            f32_basis: false,
        }
    }

    /// The default for `n` unknowns and a relative residual target `rel_target`: a `f32`
    /// basis where the system has at least [`F32_BASIS_MIN_LEN`] unknowns and the target is
    /// at least [`F32_BASIS_MIN_TARGET`] (well above the basis' rounding), else
    /// [`GmresParams::for_len`].
    pub fn for_problem(n: usize, rel_target: f64) -> Self {
        Self {
            f32_basis: n >= F32_BASIS_MIN_LEN && rel_target >= F32_BASIS_MIN_TARGET,
            ..Self::for_len(n)
        }
    }
}

/// Fewest unknowns for which [`GmresParams::for_problem`] stores the basis in `f32`: below
/// it the basis is small (under 24 MB per vector) and memory is not what limits a solve.
pub const F32_BASIS_MIN_LEN: usize = 3_000_000;

/// Smallest relative residual target for which [`GmresParams::for_problem`] stores the basis
/// in `f32`: 1e-6, about 16 times `f32`'s rounding.
pub const F32_BASIS_MIN_TARGET: f64 = 1e-6;

/// GMRES restart length for `n` unknowns: the Krylov basis holds `m + 1` vectors, so `m`
/// shrinks for large systems to keep it within ~400 MB (at least 20); at most 30, beyond
/// which the orthogonalisation costs more than the saved iterations (measured on the
/// checkerboard P_3/P_5).
pub fn gmres_restart(n: usize) -> usize {
    let budget = 400_000_000 / (8 * n.max(1));
    budget.clamp(20, 30)
}

/// GMRES on `a x = f` from `x` with the preconditioner `m` and the default parameters for
/// the system's size and the controller's target ([`GmresParams::for_problem`]).
pub fn gmres(
    a: &dyn LinearOperator,
    m: &dyn Preconditioner,
    f: &[f64],
    x: &mut [f64],
    ctl: &mut Control,
) -> Outcome {
    let rel_target = if ctl.scale > 0.0 {
        ctl.target / ctl.scale
    } else {
        0.0
    };
    gmres_with(
        &GmresParams::for_problem(f.len(), rel_target),
        a,
        m,
        f,
        x,
        ctl,
    )
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
    if params.f32_basis {
        run::<f32>(params.restart, a, precond, f, x, ctl)
    } else {
        run::<f64>(params.restart, a, precond, f, x, ctl)
    }
}

/// A stored basis entry: `f64`, or `f32` (read as `f64` by `linalg::dot` and `axpy`).
trait BasisValue: Copy + Into<f64> + Send + Sync {
    fn store(v: f64) -> Self;
    /// The slice itself where it is already `f64`.
    fn as_f64(v: &[Self]) -> Option<&[f64]>;
}

impl BasisValue for f64 {
    #[inline]
    fn store(v: f64) -> Self {
        v
    }
    fn as_f64(v: &[Self]) -> Option<&[f64]> {
        Some(v)
    }
}

impl BasisValue for f32 {
    #[inline]
    fn store(v: f64) -> Self {
        v as f32
    }
    fn as_f64(_: &[Self]) -> Option<&[f64]> {
        None
    }
}

/// `v / s`, stored.
fn scaled<V: BasisValue>(v: &[f64], s: f64) -> Vec<V> {
    v.par_iter().map(|a| V::store(a / s)).collect()
}

fn run<V: BasisValue>(
    restart: usize,
    a: &dyn LinearOperator,
    precond: &dyn Preconditioner,
    f: &[f64],
    x: &mut [f64],
    ctl: &mut Control,
) -> Outcome {
    let n = f.len();
    let m = restart.max(1);
    let mut r = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut z = vec![0.0; n];
    // The current direction in f64 for the preconditioner (a copy only for an f32 basis).
    let mut direction: Vec<f64> = Vec::new();
    let mut basis: Vec<Vec<V>> = Vec::with_capacity(m + 1);
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
        basis.push(scaled(&r, beta));
        let mut outcome = None;
        let mut k = 0;
        while k < m {
            let vk: &[f64] = match V::as_f64(&basis[k]) {
                Some(v) => v,
                None => {
                    direction.resize(n, 0.0);
                    direction
                        .par_iter_mut()
                        .zip(&basis[k])
                        .for_each(|(d, &b)| *d = b.into());
                    &direction
                }
            };
            precond.apply(vk, &mut z);
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
            basis.push(scaled(&w, wn));
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
        let p = GmresParams {
            restart: 3,
            f32_basis: false,
        };
        super::super::cg::tests::check(|a, x, f, ctl| gmres_with(&p, a, &id, f, x, ctl), -1.5, 0.5);
    }

    /// With the basis in `f32` GMRES still reaches a relative residual of 1e-12, far below
    /// `f32`'s rounding: each restart starts from the true `f64` residual (iterative
    /// refinement), with a short and a long restart length.
    #[test]
    fn gmres_with_an_f32_basis_reaches_f64_accuracy() {
        let id = crate::operator::Identity;
        for restart in [5, 30] {
            let p = GmresParams {
                restart,
                f32_basis: true,
            };
            super::super::cg::tests::check(
                |a, x, f, ctl| gmres_with(&p, a, &id, f, x, ctl),
                -1.5,
                0.5,
            );
        }
        // The default picks it only for large systems and modest targets.
        assert!(GmresParams::for_problem(8_000_000, 1e-6).f32_basis);
        assert!(!GmresParams::for_problem(8_000_000, 1e-8).f32_basis);
        assert!(!GmresParams::for_problem(100_000, 1e-4).f32_basis);
    }
}
