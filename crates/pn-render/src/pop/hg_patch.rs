//! The Henyey–Greenstein cumulative distribution (POP paper Eq. 1) and the six solid-angle
//! patches of the propagation stencil (Eqs. 2–3).
//!
//! A cell's radiance is `L · f_hg(ω·d, a)` with `f_hg` normalised over the sphere
//! (`∫ f_hg dω = 1`), so `L` is the lobe's integral over all directions and `a` ∈ [0, 1] its
//! mean cosine about the principal direction `d`.
//!
//! **Eq. 1, rewritten** (open point 5 of `../shared/papers/README.md`; docs/pop-design.md):
//! the printed `F(μ, g) = (1 − g²)/(4πg) · (1/s − 1/(1 + g))`, `s = √(1 + g² − 2gμ)`, is
//! 0/0 at g = 0. Multiplying `1/s − 1/(1+g) = (1 + g − s)/(s(1 + g))` by
//! `(1 + g + s)/(1 + g + s)` and using `(1 + g)² − s² = 2g(1 + μ)` gives the form without the
//! singularity,
//!
//! ```text
//! F(μ, g) = (1 − g)(1 + μ) / (2π s (1 + g + s)),
//! ```
//!
//! with `F(μ, 0) = (1 + μ)/(4π)` and `F(1, g) = 1/(2π)` for every g < 1. `F` is the integral
//! over μ′ ∈ [−1, μ] of `f_hg(μ′, g)` per unit azimuth, so `2π F(1, g) = 1`. For
//! `g ≥ 1 −` [`DELTA_EPS`] the lobe is a Dirac delta along `d`: `F = 1/(2π)` at μ = 1 and 0
//! below (the rewritten formula would be 0/0 at μ = 1 there).
//!
//! **Eq. 3**: the cell in front of the source receives the cone θ ∈ [0, π/4] (all azimuths),
//! each of the four side cells a quarter (|φ₁ − φ₂| = π/2) of the band θ ∈ [π/4, 3π/4], the
//! cell behind the cone θ ∈ [3π/4, π]. These patches tile the sphere, so the six fractions
//! sum to `2π F(1) = 1` exactly (up to rounding): POP's propagation moves energy, it never
//! creates or loses any except through absorption and the grid's faces.

use std::f64::consts::{FRAC_1_SQRT_2, PI};

/// Lobes with `a ≥ 1 − DELTA_EPS` are treated as a Dirac delta along the principal direction
/// (all energy to the cell in front).
pub const DELTA_EPS: f64 = 1e-12;

/// `F(μ, a) = ∫_{−1}^{μ} f_hg(μ′, a) dμ′` (per unit azimuth) in the rewritten, non-singular
/// form of the module docs; μ is clamped to [−1, 1], `a` must lie in [0, 1].
pub fn hg_cdf(mu: f64, a: f64) -> f64 {
    let mu = mu.clamp(-1.0, 1.0);
    if a >= 1.0 - DELTA_EPS {
        return if mu >= 1.0 { 1.0 / (2.0 * PI) } else { 0.0 };
    }
    // s² = 1 + a² − 2aμ written as (1 − a)² + 2a(1 − μ): no cancellation for a, μ → 1.
    let s = ((1.0 - a) * (1.0 - a) + 2.0 * a * (1.0 - mu)).sqrt();
    (1.0 - a) * (1.0 + mu) / (2.0 * PI * s * (1.0 + a + s))
}

/// The fractions of a source cell's energy that Eq. 2 sends to each of its six neighbours
/// (before absorption): `front + 4·side + back = 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Patches {
    /// To the neighbour in front (θ ∈ [0, π/4]): `2π (F(1) − F(cos π/4))`.
    pub front: f64,
    /// To **each** of the four side neighbours (θ ∈ [π/4, 3π/4], |φ₁ − φ₂| = π/2):
    /// `π/2 (F(cos π/4) − F(−cos π/4))`.
    pub side: f64,
    /// To the neighbour behind (θ ∈ [3π/4, π]): `2π (F(−cos π/4) − F(−1))`.
    pub back: f64,
}

impl Patches {
    /// The fractions for a lobe of anisotropy `a` ∈ [0, 1] (Eq. 2 with Eq. 3's patches).
    pub fn of(a: f64) -> Patches {
        let f_hi = hg_cdf(FRAC_1_SQRT_2, a);
        let f_lo = hg_cdf(-FRAC_1_SQRT_2, a);
        // F(1) = 1/(2π) and F(−1) = 0 exactly; writing front as 1 − 2πF(cos π/4) keeps the
        // sum at 1 to rounding.
        Patches {
            front: 1.0 - 2.0 * PI * f_hi,
            side: 0.5 * PI * (f_hi - f_lo),
            back: 2.0 * PI * f_lo,
        }
    }

    /// The fraction towards one neighbour through patch `which` (0 front, 1 side, 2 back:
    /// [`super::propagate::FRONT`], `SIDE`, `BACK`).
    #[inline(always)]
    pub fn towards(&self, which: u8) -> f64 {
        match which {
            0 => self.front,
            2 => self.back,
            _ => self.side,
        }
    }

    /// `front + 4·side + back` (1 up to rounding).
    pub fn total(&self) -> f64 {
        self.front + 4.0 * self.side + self.back
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pn_stencil::quadrature::{gauss_legendre, henyey_greenstein};

    /// Test 2 of issue 20: Eq. 3's patches partition the sphere, Σ = 1 to rounding (1e-14:
    /// a handful of operations on numbers ≤ 1), for g = 0, moderate, strong and delta lobes;
    /// all fractions are non-negative.
    #[test]
    fn patches_partition_the_sphere() {
        for a in [
            0.0,
            0.1,
            0.3,
            0.5,
            0.7,
            0.9,
            0.95,
            0.99,
            0.999,
            1.0 - 1e-9,
            1.0 - 1e-13,
        ] {
            let p = Patches::of(a);
            assert!((p.total() - 1.0).abs() < 1e-14, "a = {a}: {p:?}");
            assert!(
                p.front >= 0.0 && p.side >= 0.0 && p.back >= 0.0,
                "a = {a}: {p:?}"
            );
        }
        // g = 0: the cone of half-angle π/4 holds (1 − cos π/4)/2 of the sphere.
        let iso = Patches::of(0.0);
        assert!((iso.front - (1.0 - FRAC_1_SQRT_2) / 2.0).abs() < 1e-15);
        assert!((iso.back - iso.front).abs() < 1e-15);
        // The delta lobe sends everything forward.
        assert_eq!(Patches::of(1.0 - 1e-13).front, 1.0);
        // Forward scattering sends more forward than backward, and more with larger a.
        assert!(Patches::of(0.99).front > Patches::of(0.7).front);
        assert!(Patches::of(0.7).front > Patches::of(0.7).back);
    }

    /// The rewritten Eq. 1 is the cumulative distribution of HG: 2π F(μ) against a 200-point
    /// Gauss–Legendre integral of 2π f_hg over [−1, μ] (smooth integrand for a ≤ 0.9; the
    /// quadrature error is far below 1e-10); the special values F(μ, 0) = (1+μ)/(4π) and
    /// F(1, g) = 1/(2π).
    #[test]
    fn rewritten_cdf_integrates_hg() {
        let (x, w) = gauss_legendre(200);
        for a in [0.0, 0.2, 0.5, 0.9] {
            for mu in [-0.9, -FRAC_1_SQRT_2, 0.0, 0.3, FRAC_1_SQRT_2, 1.0] {
                let half = 0.5 * (mu + 1.0);
                let integral: f64 = x
                    .iter()
                    .zip(&w)
                    .map(|(t, wt)| {
                        let m = -1.0 + half * (t + 1.0);
                        half * wt * 2.0 * PI * henyey_greenstein(a, m)
                    })
                    .sum();
                let f = 2.0 * PI * hg_cdf(mu, a);
                assert!(
                    (f - integral).abs() < 1e-10,
                    "a {a} mu {mu}: {f} vs {integral}"
                );
            }
        }
        for mu in [-1.0, -0.4, 0.25, 1.0] {
            assert!((hg_cdf(mu, 0.0) - (1.0 + mu) / (4.0 * PI)).abs() < 1e-16);
        }
        for a in [0.0, 0.5, 0.99, 0.999_999] {
            assert!((hg_cdf(1.0, a) - 1.0 / (2.0 * PI)).abs() < 1e-12, "a = {a}");
            assert_eq!(hg_cdf(-1.0, a), 0.0);
        }
    }
}
