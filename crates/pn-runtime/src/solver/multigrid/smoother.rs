//! Jacobi-preconditioned Chebyshev smoothing (parallel, symmetric).
//!
//! The smoother is the Chebyshev polynomial of degree `k` in `D⁻¹A` that is smallest on
//! `[λ_max/ratio, λ_max]` (the high-frequency part of the spectrum of `D⁻¹A`), applied
//! as the classical three-term recurrence (Saad, *Iterative Methods*, Alg. 12.1). It is a
//! fixed polynomial `p(D⁻¹A)D⁻¹`, which is self-adjoint when `A` is, so the same smoother
//! before and after the coarse correction gives a symmetric V-cycle. Degree 1 is damped
//! Jacobi with `ω = 1/θ`, `θ` the centre of the interval.

use crate::linalg::{norm, Real};
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
    /// A smoother on `[λ_max/ratio, λ_max]` with `λ_max` estimated by power iteration.
    pub fn new(
        apply: &dyn Fn(&[f64], &mut [f64]),
        inv_diag: Vec<f64>,
        degree: usize,
        ratio: f64,
        power_steps: usize,
    ) -> Self {
        // The power iteration underestimates λ_max; 10% margin keeps the top of the
        // spectrum inside the damped interval (a missed eigenvalue would be amplified).
        let lambda_max = 1.1 * estimate_lambda_max(apply, &inv_diag, power_steps);
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
        let theta = 0.5 * (self.lambda_max + self.lambda_min);
        let delta = 0.5 * (self.lambda_max - self.lambda_min);
        let sigma = theta / delta;
        let mut rho = 1.0 / sigma;
        let theta_t = T::of(theta);
        d.par_iter_mut()
            .zip(x.par_iter_mut())
            .zip(r.par_iter().zip(inv.par_iter()))
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|((di, xi), (&ri, &ii))| {
                *di = ri * ii / theta_t;
                *xi += *di;
            });
        for k in 1..=self.degree {
            if k == self.degree && !final_residual {
                break;
            }
            apply(d, t);
            r.par_iter_mut()
                .zip(t.par_iter())
                .with_min_len(super::PAR_MIN_LEN)
                .for_each(|(ri, &ti)| *ri -= ti);
            if k == self.degree {
                break;
            }
            let rho_new = 1.0 / (2.0 * sigma - rho);
            let (c1, c2) = (T::of(rho_new * rho), T::of(2.0 * rho_new / delta));
            d.par_iter_mut()
                .zip(x.par_iter_mut())
                .zip(r.par_iter().zip(inv.par_iter()))
                .with_min_len(super::PAR_MIN_LEN)
                .for_each(|((di, xi), (&ri, &ii))| {
                    *di = c1 * *di + c2 * ri * ii;
                    *xi += *di;
                });
            rho = rho_new;
        }
    }
}

/// `λ_max(D⁻¹A)` by `steps` power iterations from a fixed pseudo-random start.
pub fn estimate_lambda_max(
    apply: &dyn Fn(&[f64], &mut [f64]),
    inv_diag: &[f64],
    steps: usize,
) -> f64 {
    let n = inv_diag.len();
    if n == 0 {
        return 1.0;
    }
    // Deterministic start with all frequencies present.
    let mut v = pseudo_random(n, 0);
    let mut w = vec![0.0; n];
    for _ in 0..steps.max(1) {
        let nv = norm(&v);
        if nv == 0.0 {
            break;
        }
        v.par_iter_mut()
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|x| *x /= nv);
        apply(&v, &mut w);
        w.par_iter_mut()
            .zip(inv_diag.par_iter())
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(wi, ii)| *wi *= ii);
        std::mem::swap(&mut v, &mut w);
    }
    // ‖D⁻¹A v‖ for the last unit v: it tends to λ_max and bounds the Rayleigh quotient
    // `vᵀD⁻¹Av` from above (a slight overestimate only widens the damped interval).
    norm(&v)
}

/// `n` deterministic pseudo-random values in [−½, ½) (SplitMix64 of index and `seed`).
pub fn pseudo_random(n: usize, seed: u64) -> Vec<f64> {
    (0..n as u64)
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

    /// 1D Laplacian tridiag(−1, 2, −1): λ_max(D⁻¹A) = 1 + cos(π/(n+1)) → 2.
    #[test]
    fn power_iteration_and_smoothing_reduce_oscillatory_error() {
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
        // Power iteration from below, the ‖D⁻¹Av‖ bound from above: within 5%.
        assert!((est - exact).abs() < 0.05 * exact, "{est} vs {exact}");
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
        assert!(err < 0.2 * norm(&e0), "error {err}");
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
