//! Point-source solutions smoothed by a 3D Gaussian source profile (for convergence studies,
//! docs/design.md §7: a single-cell source is not resolved by refinement, a Gaussian is).
//!
//! Every P_N mode is a multiple of the Yukawa potential `f(x) = e^{−κ|x|}/|x|`; its
//! convolution with the normalised isotropic Gaussian `G_s` (standard deviation s per axis) is
//! radial, and integrating the angles analytically leaves
//!
//! ```text
//!     (f∗G_s)(R) = 1/(R s√(2π)) ∫_0^∞ e^{−κr} [e^{−(R−r)²/2s²} − e^{−(R+r)²/2s²}] dr
//!                = 1/(2R) [e^{κ²s²/2 − κR} erfc(x₁) − e^{κ²s²/2 + κR} erfc(x₂)],
//!     x₁ = (κs² − R)/(s√2),  x₂ = (κs² + R)/(s√2).
//! ```
//!
//! With `erfcx(x) = e^{x²} erfc(x)` and `x₁,₂² = κ²s²/2 ∓ κR + R²/2s²` this is evaluated
//! without overflow for any κs and R (all exponentials below have non-positive arguments):
//! * `x₁ ≥ 0`: `e^{−R²/2s²} (erfcx(x₁) − erfcx(x₂)) / (2R)`;
//! * `x₁ < 0`: `(2e^{κ²s²/2 − κR} − e^{−R²/2s²}(erfcx(−x₁) + erfcx(x₂))) / (2R)`
//!   (using `erfc(x₁) = 2 − erfc(−x₁)`; `κR > κ²s²` there, so the first exponent is ≤ 0);
//! * `R ≪ s` (δ = R/(s√2) < 10⁻²), where both forms cancel: the odd Taylor series in δ of
//!   `erfcx(x₀ − δ) − erfcx(x₀ + δ)`, `x₀ = κs/√2`, with the derivatives from
//!   `F' = 2xF − 2/√π`, `F^{(n+1)} = 2xF^{(n)} + 2nF^{(n−1)}`.
//!
//! Accuracy: about 1e-13 relative for κs ≲ 10; for large κs the direct forms near the
//! switch lose ≈ ε·κs/δ to cancellation (≈ 1e-12 at κs = 100), still far below what any
//! discretization study resolves. Far from the source (`R ≫ s`) the result tends to
//! `e^{κ²s²/2} e^{−κR}/R`.

//!
//! The matching discrete source: an isotropic source of unit power with profile G_s centred at
//! x_0 has `Q_0^0(x) = G_s(|x − x_0|)/√(4π)` (Q = q/(4π) with ∫q = 1, and `Q_0^0 = ∫Q Y_0^0`).
//! Then `φ = √(4π) L_0^0` is [`crate::reference::PointSourceModes::fluence_gaussian_world`].

use std::f64::consts::{PI, SQRT_2};

use super::special::erfcx;

/// 2/√π.
const FRAC_2_SQRT_PI: f64 = std::f64::consts::FRAC_2_SQRT_PI;

/// Below this δ = R/(s√2) the Taylor branch is used (truncation ≲ δ⁶/5040·|F⁽⁷⁾/F'| ≈ 1e-14,
/// while the direct forms lose ≈ ε/δ ≈ 1e-14 to cancellation at the switch).
const TAYLOR_DELTA: f64 = 1e-2;

/// `erfcx'(x) = 2x erfcx(x) − 2/√π`, given `f0 = erfcx(x)`. For x ≥ 8 that difference loses
/// ~2εx² to cancellation, so there the asymptotic series
/// `erfcx'(x) = (1/√π) Σ_{k≥0} (−1)^{k+1} (2k+1)!! / (2^k x^{2k+2})` is summed instead (its
/// terms shrink by (2k+3)/(2x²) ≤ 1/4 for the ≤ 30 terms needed at x ≥ 8).
fn erfcx_derivative(x: f64, f0: f64) -> f64 {
    if x < 8.0 {
        return 2.0 * x * f0 - FRAC_2_SQRT_PI;
    }
    let inv2x2 = 0.5 / (x * x);
    let mut term = -1.0 / (x * x); // k = 0: −1/x²
    let mut sum = term;
    for k in 1..60 {
        term *= -((2 * k + 1) as f64) * inv2x2;
        sum += term;
        if term.abs() < 1e-17 * sum.abs() {
            break;
        }
    }
    0.5 * FRAC_2_SQRT_PI * sum
}

/// Normalised isotropic 3D Gaussian `(2πs²)^{−3/2} e^{−r²/(2s²)}` (unit integral).
pub fn gaussian_3d(r: f64, s: f64) -> f64 {
    (2.0 * PI * s * s).powf(-1.5) * (-(r * r) / (2.0 * s * s)).exp()
}

/// The Yukawa potential `e^{−κ|x|}/|x|` convolved with [`gaussian_3d`] of standard deviation
/// `s`, evaluated at distance `r` from the centre (see the module documentation). Needs κ ≥ 0
/// and s ≥ 0 (s = 0 returns `e^{−κr}/r`); finite at r = 0.
pub fn yukawa_gaussian(r: f64, kappa: f64, s: f64) -> f64 {
    let r = r.abs();
    if s == 0.0 {
        return (-kappa * r).exp() / r;
    }
    if !(s > 0.0 && kappa >= 0.0) {
        return f64::NAN;
    }
    let sq = s * SQRT_2;
    let delta = r / sq;
    let x0 = kappa * s / SQRT_2;
    if delta < TAYLOR_DELTA {
        // e^{−δ²} (F(x0−δ) − F(x0+δ)) / (2R) = −e^{−δ²}/(s√2) (F' + F'''δ²/6 + F⁽⁵⁾δ⁴/120).
        let f0 = erfcx(x0);
        let f1 = erfcx_derivative(x0, f0);
        let f2 = 2.0 * x0 * f1 + 2.0 * f0;
        let f3 = 2.0 * x0 * f2 + 4.0 * f1;
        let f4 = 2.0 * x0 * f3 + 6.0 * f2;
        let f5 = 2.0 * x0 * f4 + 8.0 * f3;
        let d2 = delta * delta;
        return -(-d2).exp() / sq * (f1 + f3 * d2 / 6.0 + f5 * d2 * d2 / 120.0);
    }
    let x1 = x0 - delta;
    let x2 = x0 + delta;
    let gauss = (-delta * delta).exp(); // e^{−R²/2s²}
    if x1 >= 0.0 {
        gauss * (erfcx(x1) - erfcx(x2)) / (2.0 * r)
    } else {
        let far = 2.0 * (x0 * x0 - kappa * r).exp();
        (far - gauss * (erfcx(-x1) + erfcx(x2))) / (2.0 * r)
    }
}
