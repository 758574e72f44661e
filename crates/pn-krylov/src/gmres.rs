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
//! **Single-precision basis.** On systems solved to a modest tolerance the basis is stored
//! in `f32` ([`GmresParams::f32_basis`]): half the memory of the largest array of the solve
//! (the 80³ P_5 point source: 19 vectors of 7.8 M unknowns, 1.2 GB in `f64`), half the
//! traffic of the orthogonalisation and half the pages each new basis vector touches first
//! (the 40³ P_5 point source: 11 iterations either way, assembly + solve 0.717 → 0.682 s,
//! medians of five alternating runs; no difference at 16³–32³). Products, projections and the update of `x` are
//! accumulated in `f64`; only the stored directions are rounded (relative 6e-8), which
//! perturbs the Krylov space, not the answer's check: the method's residual estimate is
//! confirmed with the true `f64` residual before the solve reports convergence, and the
//! caller continues from there if it is not met.

use crate::control::{true_residual, Control, Outcome};
use crate::linalg::{axpy, lane_dot, norm};
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
    /// basis where the target is at least [`F32_BASIS_MIN_TARGET`] (well above the basis'
    /// rounding), else [`GmresParams::for_len`].
    pub fn for_problem(n: usize, rel_target: f64) -> Self {
        Self {
            f32_basis: rel_target >= F32_BASIS_MIN_TARGET,
            ..Self::for_len(n)
        }
    }
}

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
    /// Whether the stored value is the `f64` itself (no separate `f64` direction needed).
    const IS_F64: bool;
    fn store(v: f64) -> Self;
    /// The slice itself where it is already `f64`.
    fn as_f64(v: &[Self]) -> Option<&[f64]>;
}

impl BasisValue for f64 {
    const IS_F64: bool = true;
    #[inline]
    fn store(v: f64) -> Self {
        v
    }
    fn as_f64(v: &[Self]) -> Option<&[f64]> {
        Some(v)
    }
}

impl BasisValue for f32 {
    const IS_F64: bool = false;
    #[inline]
    fn store(v: f64) -> Self {
        v as f32
    }
    fn as_f64(_: &[Self]) -> Option<&[f64]> {
        None
    }
}

/// `v / s`, stored; for an `f32` basis also widened into `direction` in the same pass (the
/// `f64` copy of the newest basis vector that the preconditioner reads).
fn scaled<V: BasisValue>(v: &[f64], s: f64, direction: &mut Vec<f64>) -> Vec<V> {
    if V::IS_F64 {
        return v.par_iter().map(|a| V::store(a / s)).collect();
    }
    direction.resize(v.len(), 0.0);
    let mut stored: Vec<V> = vec![V::store(0.0); v.len()];
    stored
        .par_iter_mut()
        .zip(direction.par_iter_mut())
        .zip(v.par_iter())
        .with_min_len(GS_BLOCK)
        .for_each(|((o, d), a)| {
            *o = V::store(a / s);
            *d = (*o).into();
        });
    stored
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
        basis.push(scaled(&r, beta, &mut direction));
        let mut outcome = None;
        let mut k = 0;
        while k < m {
            // The newest basis vector, or its f64 copy made when it was stored.
            let vk: &[f64] = V::as_f64(&basis[k]).unwrap_or(&direction);
            precond.apply(vk, &mut z);
            a.apply(&z, &mut w);
            ctl.applications += 1;
            // Classical Gram–Schmidt, fused: all projections in one sweep over the basis,
            // all subtractions and the new norm in a second (2k + 2 vector passes instead of
            // modified Gram–Schmidt's 5k); repeated once where the first pass cancelled nearly all
            // of `w` ([`REORTHOGONALIZE`]).
            let mut col = vec![0.0; k + 2];
            let (proj, before) = project(&w, &basis);
            let mut wn = subtract(&mut w, &basis, &proj);
            col[..=k].copy_from_slice(&proj);
            if wn < REORTHOGONALIZE * before {
                let (again, _) = project(&w, &basis);
                wn = subtract(&mut w, &basis, &again);
                col.iter_mut().zip(&again).for_each(|(c, a)| *c += a);
            }
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
            basis.push(scaled(&w, wn, &mut direction));
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
        let minus_y: Vec<f64> = y.iter().map(|v| -v).collect();
        subtract(&mut w, &basis[..k], &minus_y);
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

/// Second Gram–Schmidt pass when `‖w‖` after the first is below this share of its norm
/// before. A classical pass leaves `w` orthogonal to the basis up to about
/// `u · ‖w_before‖ / ‖w_after‖` (`u` the unit roundoff of the basis; Giraud, Langou and
/// Rozložník 2005), so a cancellation to 1 % costs at most a factor 100 on `u`; below it the
/// pass is repeated, which restores working precision ("twice is enough"). The common
/// DGKS threshold `1/√2` repeated every step of the preconditioned solves (`‖w‖` falls to
/// about a third: 80³ P_5 point source, every one of 18 steps), doubling the sweeps for
/// nothing the tolerance needs.
const REORTHOGONALIZE: f64 = 0.01;

/// Values per block of the fused Gram–Schmidt sweeps: a block of `w` (16 KB) stays in the
/// first-level cache while every basis vector's block is read.
const GS_BLOCK: usize = 2048;

/// The projections `⟨w, v_i⟩` on every basis vector, and `‖w‖`, in one sweep.
fn project<V: BasisValue>(w: &[f64], basis: &[Vec<V>]) -> (Vec<f64>, f64) {
    let k = basis.len();
    let block = |c: usize, ws: &[f64]| {
        let mut acc = vec![0.0; k + 1];
        let at = c * GS_BLOCK;
        for (a, v) in acc.iter_mut().zip(basis) {
            *a = lane_dot(ws, &v[at..at + ws.len()]);
        }
        acc[k] = lane_dot(ws, ws);
        acc
    };
    let add = |mut a: Vec<f64>, b: Vec<f64>| {
        a.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
        a
    };
    // Partial sums per block, added in order: deterministic (see `linalg::REDUCE_CHUNK`).
    let parts: Vec<Vec<f64>> = if w.len() < 4 * GS_BLOCK {
        w.chunks(GS_BLOCK)
            .enumerate()
            .map(|(c, ws)| block(c, ws))
            .collect()
    } else {
        w.par_chunks(GS_BLOCK)
            .enumerate()
            .map(|(c, ws)| block(c, ws))
            .collect()
    };
    let mut acc = parts.into_iter().fold(vec![0.0; k + 1], add);
    let wn = acc.pop().unwrap_or(0.0).sqrt();
    (acc, wn)
}

/// `w −= Σ_i c_i v_i` over the basis vectors `v_i` paired with `c`, in one sweep; returns
/// `‖w‖` of the result, summed in the same sweep (per block, the blocks' sums added in
/// order: deterministic).
fn subtract<V: BasisValue>(w: &mut [f64], basis: &[Vec<V>], c: &[f64]) -> f64 {
    let block = |b: usize, ws: &mut [f64]| {
        let (at, len) = (b * GS_BLOCK, ws.len());
        for (v, &ci) in basis.iter().zip(c) {
            ws.iter_mut()
                .zip(&v[at..at + len])
                .for_each(|(x, &y)| *x -= ci * y.into());
        }
        lane_dot(ws, ws)
    };
    let parts: Vec<f64> = if w.len() < 4 * GS_BLOCK {
        w.chunks_mut(GS_BLOCK)
            .enumerate()
            .map(|(b, ws)| block(b, ws))
            .collect()
    } else {
        w.par_chunks_mut(GS_BLOCK)
            .enumerate()
            .map(|(b, ws)| block(b, ws))
            .collect()
    };
    parts.iter().sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gmres_solves_nonsymmetric() {
        let id = crate::operator::Identity;
        crate::cg::tests::check(|a, x, f, ctl| gmres(a, &id, f, x, ctl), -1.5, 0.5);
        // A short restart still converges (more cycles).
        let p = GmresParams {
            restart: 3,
            f32_basis: false,
        };
        crate::cg::tests::check(|a, x, f, ctl| gmres_with(&p, a, &id, f, x, ctl), -1.5, 0.5);
    }

    /// A nearly scaled identity (`3 I` plus couplings of 1e-3): each new direction `A v_k`
    /// is `3 v_k` up to about 1e-3 of its norm, so the first Gram–Schmidt pass cancels all
    /// but ~0.2 % of it and the second pass runs ([`REORTHOGONALIZE`]); the solve still
    /// reaches 1e-12.
    #[test]
    fn gmres_with_strong_cancellation_reorthogonalizes_and_converges() {
        let id = crate::operator::Identity;
        crate::cg::tests::check(|a, x, f, ctl| gmres(a, &id, f, x, ctl), -0.003, 0.002);
        let w: Vec<f64> = (0..300).map(|i| (i as f64 * 0.1).sin()).collect();
        let mut aw = vec![0.0; w.len()];
        let a = crate::cg::tests::tridiag(w.len(), -0.003, 3.0, 0.002);
        crate::operator::LinearOperator::apply(&a, &w, &mut aw);
        let v: Vec<f64> = w.iter().map(|x| x / norm(&w)).collect();
        let basis = [v];
        let (p, before) = project(&aw, &basis);
        subtract(&mut aw, &basis, &p);
        assert!(norm(&aw) < REORTHOGONALIZE * before);
    }

    /// The fused sweeps equal the plain sums, with an `f64` and an `f32` basis, on lengths
    /// below, at and above the block size and the parallel threshold.
    #[test]
    fn fused_gram_schmidt_sweeps_equal_the_plain_sums() {
        for len in [5, GS_BLOCK - 1, GS_BLOCK, 4 * GS_BLOCK + 7] {
            let w: Vec<f64> = (0..len)
                .map(|i| ((i * 7919 % 1000) as f64 / 500.0) - 1.0)
                .collect();
            let b64: Vec<Vec<f64>> = (0..3)
                .map(|j| {
                    (0..len)
                        .map(|i| ((i + 13 * j) as f64 * 0.1).sin())
                        .collect()
                })
                .collect();
            let b32: Vec<Vec<f32>> = b64
                .iter()
                .map(|v| v.iter().map(|&x| x as f32).collect())
                .collect();
            let tol = 1e-13 * len as f64;
            let (p, wn) = project(&w, &b64);
            let (p32, _) = project(&w, &b32);
            for j in 0..3 {
                let want: f64 = w.iter().zip(&b64[j]).map(|(a, b)| a * b).sum();
                let want32: f64 = w.iter().zip(&b32[j]).map(|(a, &b)| a * b as f64).sum();
                assert!((p[j] - want).abs() <= tol, "{len}: {} vs {want}", p[j]);
                assert!(
                    (p32[j] - want32).abs() <= tol,
                    "{len}: {} vs {want32}",
                    p32[j]
                );
            }
            let wn_plain = w.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!((wn - wn_plain).abs() <= 1e-13 * wn_plain);
            let c = [0.5, -1.0, 2.0];
            let mut got = w.clone();
            let got_norm = subtract(&mut got, &b32, &c);
            for i in 0..len {
                let want = w[i] - (0..3).map(|j| c[j] * b32[j][i] as f64).sum::<f64>();
                assert!((got[i] - want).abs() <= 1e-14 * 4.0, "{len}: {i}");
            }
            let norm_plain = got.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!((got_norm - norm_plain).abs() <= 1e-13 * norm_plain, "{len}");
        }
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
            crate::cg::tests::check(|a, x, f, ctl| gmres_with(&p, a, &id, f, x, ctl), -1.5, 0.5);
        }
        // The default picks it for modest targets, at any size.
        assert!(GmresParams::for_problem(8_000_000, 1e-6).f32_basis);
        assert!(!GmresParams::for_problem(8_000_000, 1e-8).f32_basis);
        assert!(GmresParams::for_problem(100_000, 1e-4).f32_basis);
        assert!(!GmresParams::for_problem(100_000, 1e-10).f32_basis);
    }
}
