//! Closed-form point-source solutions (docs/design.md §7), normalised fluence `4πφ/σ_t²` of a
//! unit-power isotropic point source at optical distance τ = σ_t r.

use anyhow::{ensure, Result};

/// Classical diffusion (CDA, identical to P_1):
///
/// ```text
///     4πφ/σ_t² = 3(1 − αg) e^{−κτ}/τ,   κ = √(3(1−α)(1−αg)).
/// ```
///
/// Derivation: CDA is `−∇·(D∇φ) + σ_a φ = δ³(x)` for a unit-power source with
/// `D = 1/(3σ_tr)` and `σ_tr = σ_t − gσ_s = σ_t(1 − αg)` (docs/design.md §2.2; φ = √(4π) L_0^0, and
/// the equation for L_0^0 with Q_0^0 = δ³/√(4π) is the same after multiplying by √(4π)).
/// Its solution is `φ = e^{−σ_eff r}/(4πD r)` with `σ_eff = √(σ_a/D) = √(3σ_a σ_tr)`, so
/// `4πφ/σ_t² = 3σ_tr/(σ_t² r) e^{−σ_eff r} = 3(1−αg)/τ · e^{−κτ}` with `κ = σ_eff/σ_t`.
/// For g = 0 this is docs/design.md's `3 e^{−√(3(1−α))τ}/τ`. P_1 with `σ_1 = σ_t − σ_s g` gives the
/// same single mode (tested against [`crate::reference::pn_point_source`]).
///
/// Plain formula: no checks on α or g (α = 1 gives the non-absorbing `3(1−g)/τ`).
pub fn cda_point_source(tau: f64, albedo: f64, g: f64) -> f64 {
    let tau = tau.abs();
    let s_tr = crate::problem::sigma_tr(1.0, albedo, g);
    let kappa = (3.0 * (1.0 - albedo) * s_tr).sqrt();
    3.0 * s_tr * (-kappa * tau).exp() / tau
}

/// Grosjean's approximation for isotropic scattering (d'Eon & Irving 2011): the exact
/// uncollided term plus a diffusion mode,
///
/// ```text
///     4πφ/σ_t² = e^{−τ}/τ² + (3α/(2−α)) e^{−λτ}/τ,   λ² = 3(1−α)/(2−α).
/// ```
pub fn grosjean(tau: f64, albedo: f64) -> f64 {
    let tau = tau.abs();
    let lambda = (3.0 * (1.0 - albedo) / (2.0 - albedo)).sqrt();
    (-tau).exp() / (tau * tau) + 3.0 * albedo / (2.0 - albedo) * (-lambda * tau).exp() / tau
}

/// The asymptotic (diffusion) mode of the exact transport solution for isotropic scattering:
/// far from the source `4πφ/σ_t² → coeff · e^{−kappa τ}/τ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransportDiffusionMode {
    /// κ_0 ∈ (0,1), the root of `(α/(2κ)) ln((1+κ)/(1−κ)) = 1`.
    pub kappa: f64,
    /// `C_0 = 2κ_0²(1−κ_0²) / (α(κ_0² + α − 1))`.
    pub coeff: f64,
}

/// The exact transport diffusion mode for isotropic scattering and albedo α ∈ (0,1), the
/// limit the slowest P_N mode approaches as N grows.
///
/// Derivation: the plane-source transport solution in Fourier space is
/// `φ̂(k) = T(k)/(1 − αT(k))` with `T(k) = arctan(k)/k` the transform of the uncollided
/// `E_1(|x|)/2`. Its pole at `k = iκ_0`, `α artanh(κ_0)/κ_0 = 1`, gives the slab term
/// `κ_0(1−κ_0²)/(α(κ_0²+α−1)) e^{−κ_0|x|}` (residue; check: for α → 1 it tends to the diffusion
/// `3/(2κ) e^{−κ|x|}`), and `φ(r) = −(1/(2πr)) dφ_slab/dr` turns it into the 3D coefficient
/// `C_0` above.
pub fn transport_diffusion_mode(albedo: f64) -> Result<TransportDiffusionMode> {
    ensure!(
        albedo.is_finite() && albedo > 0.0 && albedo < 1.0,
        "the transport diffusion mode needs an albedo in (0, 1) (got {albedo})"
    );
    // h(κ) = α artanh(κ)/κ − 1 increases from α − 1 < 0 (κ → 0) to +∞ (κ → 1): bisect.
    let h = |k: f64| albedo * k.atanh() / k - 1.0;
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if mid == 0.0 || h(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let kappa = 0.5 * (lo + hi);
    let k2 = kappa * kappa;
    let coeff = 2.0 * k2 * (1.0 - k2) / (albedo * (k2 + albedo - 1.0));
    Ok(TransportDiffusionMode { kappa, coeff })
}
