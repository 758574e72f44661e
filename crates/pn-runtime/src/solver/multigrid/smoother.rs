//! Jacobi-preconditioned Chebyshev smoothing (parallel, symmetric).
//!
//! The smoother is the Chebyshev polynomial of degree `k` in `D⁻¹A` that is smallest on
//! `[λ_max/ratio, λ_max]` (the high-frequency part of the spectrum of `D⁻¹A`), applied
//! as the classical three-term recurrence (Saad, *Iterative Methods*, Alg. 12.1). It is a
//! fixed polynomial `p(D⁻¹A)D⁻¹`, which is self-adjoint when `A` is, so the same smoother
//! before and after the coarse correction gives a symmetric V-cycle. Degree 1 is damped
//! Jacobi with `ω = 1/θ`, `θ` the centre of the interval.

use pn_krylov::linalg::Real;
use rayon::prelude::*;

/// A Chebyshev smoother for one level.
#[derive(Clone, Debug)]
pub struct Chebyshev {
    /// `1 / A_ii`.
    pub inv_diag: Vec<f64>,
    /// Upper end of the damped interval (an estimate of `λ_max(D⁻¹A)` with a margin).
    pub lambda_max: f64,
    /// Lower end.
    pub lambda_min: f64,
    /// Polynomial degree (applications of `A` per smoothing step, counting the residual).
    pub degree: usize,
}

impl Chebyshev {
    /// A smoother on `[λ_max/ratio, λ_max]` with `λ_max` estimated by `power_steps` Lanczos
    /// steps ([`estimate_lambda_max`]).
    pub fn new(
        apply: &dyn Fn(&[f64], &mut [f64]),
        inv_diag: Vec<f64>,
        degree: usize,
        ratio: f64,
        power_steps: usize,
    ) -> Self {
        // The Ritz value plus its residual bound: the margin that keeps the top of the
        // spectrum inside the damped interval (a missed eigenvalue would be amplified).
        // A further 10 % on top, as the power iteration needed, widened the interval for
        // nothing: 40³ point source P_3 / P_5 12 / 15–16 GMRES iterations against 11 / 14
        // without, 71² checkerboard P_5 55 against 53, the 32³ cloud P_7 / P_9 64–65 / 77–78
        // CG iterations against 61 / 73.
        let lambda_max = estimate_lambda_max(apply, &inv_diag, power_steps);
        Self::from_estimate(inv_diag, lambda_max, degree, ratio)
    }

    /// A smoother on `[λ_max/ratio, λ_max]` for an estimate `lambda_max` made elsewhere
    /// (the finest level's, with its `f32` operator: [`estimate_lambda_max_with`]).
    pub fn from_estimate(inv_diag: Vec<f64>, lambda_max: f64, degree: usize, ratio: f64) -> Self {
        Self {
            inv_diag,
            lambda_max,
            lambda_min: lambda_max / ratio,
            degree: degree.max(1),
        }
    }

    /// Adds `p(D⁻¹A)D⁻¹ r` to `x`. On entry `r` is the residual of `x`; on exit it is the
    /// residual of the updated `x` when `final_residual` (else partly updated). `d` and
    /// `t` are work vectors of the same length.
    pub fn smooth(
        &self,
        apply: &dyn Fn(&[f64], &mut [f64]),
        r: &mut [f64],
        x: &mut [f64],
        d: &mut [f64],
        t: &mut [f64],
        final_residual: bool,
    ) {
        self.smooth_with(&self.inv_diag, apply, r, x, d, t, final_residual);
    }

    /// [`Chebyshev::smooth`] in any [`Real`] type, with `inv` the inverse diagonal in that
    /// type (the polynomial's coefficients are computed in `f64` and rounded).
    #[allow(clippy::too_many_arguments)]
    pub fn smooth_with<T: Real>(
        &self,
        inv: &[T],
        apply: &dyn Fn(&[T], &mut [T]),
        r: &mut [T],
        x: &mut [T],
        d: &mut [T],
        t: &mut [T],
        final_residual: bool,
    ) {
        let steps = self.steps();
        let theta = T::of(steps.theta);
        d.par_iter_mut()
            .zip(x.par_iter_mut())
            .zip(r.par_iter().zip(inv.par_iter()))
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|((di, xi), (&ri, &ii))| {
                *di = ri * ii / theta;
                *xi += *di;
            });
        for &(c1, c2) in &steps.updates {
            apply(d, t);
            r.par_iter_mut()
                .zip(t.par_iter())
                .with_min_len(super::PAR_MIN_LEN)
                .for_each(|(ri, &ti)| *ri -= ti);
            let (c1, c2) = (T::of(c1), T::of(c2));
            d.par_iter_mut()
                .zip(x.par_iter_mut())
                .zip(r.par_iter().zip(inv.par_iter()))
                .with_min_len(super::PAR_MIN_LEN)
                .for_each(|((di, xi), (&ri, &ii))| {
                    *di = c1 * *di + c2 * ri * ii;
                    *xi += *di;
                });
        }
        if final_residual {
            apply(d, t);
            r.par_iter_mut()
                .zip(t.par_iter())
                .with_min_len(super::PAR_MIN_LEN)
                .for_each(|(ri, &ti)| *ri -= ti);
        }
    }

    /// The recurrence's coefficients (Saad, Alg. 12.1): the first direction is
    /// `d = D⁻¹ r / θ`, then each of the `degree − 1` further steps, after `r −= A d`, sets
    /// `d = c₁ d + c₂ D⁻¹ r` with `(c₁, c₂)` from [`ChebyshevSteps::updates`] (`x += d`
    /// after each). The fused finest level of the cycle ([`super::vcycle`]) follows the
    /// same coefficients as [`Chebyshev::smooth_with`].
    pub fn steps(&self) -> ChebyshevSteps {
        let theta = 0.5 * (self.lambda_max + self.lambda_min);
        let delta = 0.5 * (self.lambda_max - self.lambda_min);
        let sigma = theta / delta;
        let mut rho = 1.0 / sigma;
        let updates = (1..self.degree)
            .map(|_| {
                let rho_new = 1.0 / (2.0 * sigma - rho);
                let c = (rho_new * rho, 2.0 * rho_new / delta);
                rho = rho_new;
                c
            })
            .collect();
        ChebyshevSteps { theta, updates }
    }
}

/// The coefficients of one smoothing pass ([`Chebyshev::steps`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ChebyshevSteps {
    /// Centre of the damped interval: the first direction is `D⁻¹ r / θ`.
    pub theta: f64,
    /// `(c₁, c₂)` of each further step `d = c₁ d + c₂ D⁻¹ r` (`degree − 1` of them).
    pub updates: Vec<(f64, f64)>,
}

/// `λ_max(D⁻¹A)` by `steps` Lanczos steps from a fixed pseudo-random start.
///
/// `D⁻¹A` is self-adjoint in the inner product `⟨x, y⟩_D = xᵀDy` when `A` is symmetric, so
/// Lanczos in that inner product builds a tridiagonal `T` whose largest eigenvalue `θ`
/// converges to `λ_max` from below far faster than the power iteration's Rayleigh quotient
/// (the Chebyshev polynomial of the step count instead of a power: Saad, *Numerical Methods
/// for Large Eigenvalue Problems*, §6.6). The estimate is `θ + β |s_last|`, the Ritz
/// value plus its residual norm, which bounds the distance from `θ` to an eigenvalue. For
/// a slightly nonsymmetric `A` (the Neumann closure) the same recurrence works with the
/// symmetric part, whose spectrum bounds the real parts of `A`'s eigenvalues.
///
/// (Eight power iterations underestimated `λ_max` on the 32³ cloud at P_9, 4.91 against 5.61
/// after 30 steps: the top of the spectrum fell outside the smoother's interval even with
/// the 10 % margin, was amplified, and CG needed 103–134 iterations instead of 75.)
pub fn estimate_lambda_max(
    apply: &dyn Fn(&[f64], &mut [f64]),
    inv_diag: &[f64],
    steps: usize,
) -> f64 {
    estimate_lambda_max_with(apply, inv_diag, steps)
}

/// [`estimate_lambda_max`] with vectors and operator in any [`Real`] type (the finest level's
/// `f32` operator: half the bytes per step), the inner products accumulated in `f64`. The
/// estimate is a Ritz value plus its residual bound either way; in `f32` it differs from the
/// `f64` one by rounding (the smoother's interval has a margin far wider than that).
pub fn estimate_lambda_max_with<T: Real + Into<f64>>(
    apply: &dyn Fn(&[T], &mut [T]),
    inv_diag: &[T],
    steps: usize,
) -> f64 {
    let n = inv_diag.len();
    if n == 0 {
        return 1.0;
    }
    // ‖x‖_D² = Σ x_i² / inv_i.
    let d_norm = |x: &[T]| -> f64 {
        pn_krylov::linalg::chunked_sum(x, inv_diag, |x, i| {
            x.iter()
                .zip(i)
                .map(|(x, i)| x.wide() * x.wide() / i.wide())
                .sum::<f64>()
        })
        .sqrt()
    };
    // Deterministic start with all frequencies present.
    let mut q: Vec<T> = pseudo_random(n, 0).into_par_iter().map(T::of).collect();
    let nq = d_norm(&q);
    if nq == 0.0 || !nq.is_finite() {
        return 1.0;
    }
    let nq_t = T::of(nq);
    q.par_iter_mut().for_each(|x| *x = *x / nq_t);
    let mut q_prev = vec![T::default(); n];
    let mut w = vec![T::default(); n];
    let (mut alpha, mut beta) = (Vec::new(), Vec::new());
    let mut b_prev = 0.0;
    for _ in 0..steps.max(1) {
        apply(&q, &mut w);
        // α = ⟨D⁻¹Aq, q⟩_D = qᵀAq.
        let a = pn_krylov::linalg::chunked_sum(&w, &q, pn_krylov::linalg::lane_dot);
        let (at, bt) = (T::of(a), T::of(b_prev));
        w.par_iter_mut()
            .zip(inv_diag.par_iter().zip(q.par_iter().zip(q_prev.par_iter())))
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(wi, (&ii, (&qi, &pi)))| *wi = *wi * ii - at * qi - bt * pi);
        let b = d_norm(&w);
        alpha.push(a);
        beta.push(b);
        // Invariant subspace found (or a NaN from a bad operator): stop.
        if b.is_nan() || b <= 1e-12 * a.abs() {
            break;
        }
        std::mem::swap(&mut q_prev, &mut q);
        let bt = T::of(b);
        q.par_iter_mut()
            .zip(w.par_iter())
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(qi, &wi)| *qi = wi / bt);
        b_prev = b;
    }
    let m = alpha.len();
    let t = nalgebra::DMatrix::from_fn(m, m, |i, j| {
        if i == j {
            alpha[i]
        } else if i + 1 == j {
            beta[i]
        } else if j + 1 == i {
            beta[j]
        } else {
            0.0
        }
    });
    let eig = nalgebra::SymmetricEigen::new(t);
    let (k, theta) =
        eig.eigenvalues
            .iter()
            .copied()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |best, (k, v)| {
                if v > best.1 {
                    (k, v)
                } else {
                    best
                }
            });
    let residual = beta[m - 1] * eig.eigenvectors[(m - 1, k)].abs();
    let est = theta + residual;
    if est.is_finite() && est > 0.0 {
        est
    } else {
        1.0
    }
}

/// `n` deterministic pseudo-random values in [−½, ½) (SplitMix64 of index and `seed`).
pub fn pseudo_random(n: usize, seed: u64) -> Vec<f64> {
    // Each value depends on its index only: generated in parallel, the same values.
    (0..n as u64)
        .into_par_iter()
        .map(|i| {
            let mut z = i
                .wrapping_add(seed.wrapping_mul(0x2545_f491_4f6c_dd1d))
                .wrapping_mul(0x9e37_79b9_7f4a_7c15);
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use pn_krylov::linalg::norm;

    /// A spectrum dense up to its top (2000 eigenvalues evenly in (0, 1], with an arbitrary
    /// diagonal scaling `D`): the top is hard for a few power iterations (8 reach about
    /// 0.9 of λ_max here — outside a 10 % margin), while 8 Lanczos steps plus the residual
    /// bound land at or just above it, a safe upper end for the Chebyshev interval.
    #[test]
    fn lanczos_estimate_reaches_the_top_of_a_dense_spectrum() {
        let n = 2000;
        let lambda: Vec<f64> = (1..=n).map(|i| i as f64 / n as f64).collect();
        // A = D^{1/2} Λ D^{1/2} with D = diag(d): D⁻¹A is similar to Λ.
        let d: Vec<f64> = (0..n).map(|i| 1.0 + (i % 7) as f64).collect();
        let a_diag: Vec<f64> = (0..n).map(|i| d[i] * lambda[i]).collect();
        let apply = |x: &[f64], y: &mut [f64]| {
            for i in 0..n {
                y[i] = a_diag[i] * x[i];
            }
        };
        let inv: Vec<f64> = d.iter().map(|v| 1.0 / v).collect();
        let est = estimate_lambda_max(&apply, &inv, 8);
        assert!((0.99..=1.1).contains(&est), "Lanczos estimate {est}");
        // The power iteration of old, for comparison: ‖D⁻¹A v‖ after 8 steps.
        let mut v = pseudo_random(n, 0);
        let mut w = vec![0.0; n];
        for _ in 0..8 {
            let nv = norm(&v);
            v.iter_mut().for_each(|x| *x /= nv);
            apply(&v, &mut w);
            w.iter_mut().zip(&inv).for_each(|(x, i)| *x *= i);
            std::mem::swap(&mut v, &mut w);
        }
        let power = norm(&v);
        assert!(power < 0.95, "power iteration {power}");
        // In f32 (the finest level's operator): the same estimate to a few f32 roundings
        // of the 8-step recurrence, so just as safe an upper end.
        let a32: Vec<f32> = a_diag.iter().map(|&v| v as f32).collect();
        let apply32 = |x: &[f32], y: &mut [f32]| {
            for i in 0..n {
                y[i] = a32[i] * x[i];
            }
        };
        let inv32: Vec<f32> = inv.iter().map(|&v| v as f32).collect();
        let est32 = estimate_lambda_max_with(&apply32, &inv32, 8);
        assert!(
            (est32 - est).abs() <= 1e-5 * est,
            "f32 {est32} vs f64 {est}"
        );
    }

    /// 1D Laplacian tridiag(−1, 2, −1): λ_max(D⁻¹A) = 1 + cos(π/(n+1)) → 2.
    #[test]
    fn lambda_estimate_and_smoothing_reduce_oscillatory_error() {
        let n = 64;
        let lap = move |x: &[f64], y: &mut [f64]| {
            for i in 0..n {
                let mut s = 2.0 * x[i];
                if i > 0 {
                    s -= x[i - 1];
                }
                if i + 1 < n {
                    s -= x[i + 1];
                }
                y[i] = s;
            }
        };
        let exact = 1.0 + (std::f64::consts::PI / (n as f64 + 1.0)).cos();
        let est = estimate_lambda_max(&lap, &vec![0.5; n], 30);
        // The Ritz value plus its residual bound: within 5 %, and not below.
        assert!(
            (est - exact).abs() < 0.05 * exact && est >= exact,
            "{est} vs {exact}"
        );
        // Highest-frequency error (−1)^i is damped by |p(λ_max)| ≤ 1/T_k(σ) per step.
        let cheb = Chebyshev::new(&lap, vec![0.5; n], 3, 10.0, 30);
        let e0: Vec<f64> = (0..n)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let mut r = vec![0.0; n];
        lap(&e0, &mut r);
        r.iter_mut().for_each(|v| *v = -*v); // residual of x = 0 for the solution −e0… as A(0 − e0)
        let mut x = vec![0.0; n];
        let (mut d, mut t) = (vec![0.0; n], vec![0.0; n]);
        cheb.smooth(&lap, &mut r, &mut x, &mut d, &mut t, true);
        // New error x − (−e0) = x + e0.
        let err: f64 = x
            .iter()
            .zip(&e0)
            .map(|(a, b)| (a + b).powi(2))
            .sum::<f64>()
            .sqrt();
        // Every mode in the damped interval shrinks by at least 1/T_3(σ), σ = (1 + 1/ratio) /
        // (1 − 1/ratio) (0.275 for ratio 10); (−1)^i is made of the top modes, all inside.
        let sigma = (1.0 + 0.1) / (1.0 - 0.1);
        let bound = 1.0 / (4.0 * sigma * sigma * sigma - 3.0 * sigma);
        assert!(
            err <= bound * norm(&e0),
            "error {err}, bound {}",
            bound * norm(&e0)
        );
        // The returned residual is that of the updated x.
        let mut ax = vec![0.0; n];
        lap(&x, &mut ax);
        let mut want = vec![0.0; n];
        lap(&e0, &mut want);
        for i in 0..n {
            assert!((r[i] - (-want[i] - ax[i])).abs() < 1e-12);
        }
    }
}
