//! Gaussian-smoothed point-source solutions and the scaled complementary error function,
//! checked against direct numerical quadrature.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_runtime::reference::{
    erfc, erfcx, gaussian_3d, pn_point_source, yukawa_gaussian, PointSourceModes,
};
use std::f64::consts::PI;

/// Gauss–Legendre nodes and weights on [−1, 1], as (node, weight) pairs.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let (x, w) = pn_stencil::quadrature::gauss_legendre(n);
    x.into_iter().zip(w).collect()
}

/// Composite Gauss–Legendre over [a, b] split at `breaks` into panels of width ≤ `h`.
fn integrate(
    f: &dyn Fn(f64) -> f64,
    a: f64,
    b: f64,
    breaks: &[f64],
    h: f64,
    gl: &[(f64, f64)],
) -> f64 {
    let mut pts = vec![a];
    pts.extend(breaks.iter().copied().filter(|x| *x > a && *x < b));
    pts.push(b);
    pts.sort_by(f64::total_cmp);
    let mut sum = 0.0;
    for w in pts.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        let panels = ((hi - lo) / h).ceil().max(1.0) as usize;
        let ph = (hi - lo) / panels as f64;
        for p in 0..panels {
            let c = lo + (p as f64 + 0.5) * ph;
            for (x, wt) in gl {
                sum += wt * 0.5 * ph * f(c + 0.5 * ph * x);
            }
        }
    }
    sum
}

fn rel_err(got: f64, want: f64) -> f64 {
    (got - want).abs() / want.abs()
}

/// erfcx against quadrature of its integral representation
/// `erfcx(x) = (2/√π) ∫_0^∞ e^{−t² − 2xt} dt`, on both sides of the branch switch at 1.25.
/// The integrand is smooth and decays on the scale min(1, 1/x): 20-point panels of width
/// ≤ min(0.25, 0.1/x) reach ~1e-15, so 1e-13 relative is a real test of the 1e-15 code.
#[test]
fn erfcx_matches_quadrature() {
    let gl = gauss_legendre(20);
    for &x in &[
        0.0f64, 0.1, 0.7, 1.2499, 1.25, 1.2501, 2.0, 3.7, 8.0, 30.0, 500.0,
    ] {
        let h = (0.25f64).min(0.1 / x.max(1e-300));
        let t_max = if x > 1.0 { 40.0 / x } else { 9.0 };
        let q =
            2.0 / PI.sqrt() * integrate(&|t| (-t * t - 2.0 * x * t).exp(), 0.0, t_max, &[], h, &gl);
        let got = erfcx(x);
        assert!(
            rel_err(got, q) < 1e-13,
            "erfcx({x}) = {got}, quadrature {q}"
        );
    }
}

/// erfc against values to 17 digits (mpmath, 40 digits), negative arguments by reflection.
#[test]
fn erfc_matches_tabulated_values() {
    let table = [
        (0.5, 0.479_500_122_186_953_5),
        (1.0, 0.157_299_207_050_285_13),
        (2.0, 0.004_677_734_981_047_266),
        (5.0, 1.537_459_794_428_035e-12),
        (10.0, 2.088_487_583_762_545e-45),
    ];
    for (x, want) in table {
        assert!(
            rel_err(erfc(x), want) < 4e-15,
            "erfc({x}) = {} vs {want}",
            erfc(x)
        );
        assert!(rel_err(erfc(-x), 2.0 - want) < 4e-15, "erfc(-{x})");
    }
    assert!((erfcx(-1.0) - (2.0 * 1f64.exp() - erfcx(1.0))).abs() < 1e-14);
    assert_eq!(erfcx(f64::INFINITY), 0.0);
    assert!(erfcx(f64::NAN).is_nan());
}

/// (e^{−κ|x|}/|x|) ∗ G_s at distance R by direct numerical quadrature over the source point:
/// spherical coordinates (ρ, μ) around the evaluation point, and in place of μ the distance
/// q = |evaluation point − source point| (Jacobian q dq/(Rρ)), so that each dimension is
/// integrated numerically over a smooth integrand:
///     ∫_0^∞ dρ ρ² f(ρ) ∫_{|R−ρ|}^{R+ρ} 2π G_s(q) q dq / (Rρ).
/// R = 0 is the 1D integral ∫ 4πρ² f(ρ) G_s(ρ) dρ. G_s is negligible (< e^{−72}) beyond 12s.
fn yukawa_gaussian_by_quadrature(r: f64, kappa: f64, s: f64) -> f64 {
    let gl = gauss_legendre(20);
    let q_max = 12.0 * s;
    let h = (s.min(1.0 / kappa.max(1e-12))) / 4.0;
    if r == 0.0 {
        return integrate(
            &|rho| 4.0 * PI * rho * (-kappa * rho).exp() * gaussian_3d(rho, s),
            0.0,
            q_max,
            &[],
            h,
            &gl,
        );
    }
    let inner = |rho: f64| {
        let lo = (r - rho).abs();
        let hi = (r + rho).min(q_max);
        if hi <= lo {
            return 0.0;
        }
        let g = |q: f64| 2.0 * PI * gaussian_3d(q, s) * q;
        integrate(&g, lo, hi, &[], s / 2.0, &gl) / (r * rho)
    };
    let lo = (r - q_max).max(0.0);
    integrate(
        &|rho| rho * (-kappa * rho).exp() * inner(rho),
        lo,
        r + q_max,
        &[r],
        h,
        &gl,
    )
}

/// The erfcx closed form against the quadrature above, over κ (0 = Coulomb, to 20), s and
/// R ∈ [0, 10s], covering all three branches (Taylor for R < 0.014s, x₁ ≥ 0, x₁ < 0).
/// Quadrature error is ~1e-13 with these panels; 1e-10 relative.
#[test]
fn yukawa_gaussian_matches_3d_quadrature() {
    for &kappa in &[0.0, 0.5, 3.0, 20.0] {
        for &s in &[0.05, 0.3, 1.0] {
            for &rs in &[0.0, 1e-4, 0.005, 0.02, 0.5, 1.0, 3.0, 10.0] {
                let r = rs * s;
                let got = yukawa_gaussian(r, kappa, s);
                let want = yukawa_gaussian_by_quadrature(r, kappa, s);
                assert!(
                    rel_err(got, want) < 1e-10,
                    "kappa={kappa} s={s} r={r}: closed form {got}, quadrature {want}"
                );
            }
        }
    }
}

/// The Taylor branch and the direct branches join continuously (δ = R/(s√2) = 1e-2 is the
/// switch): values just either side agree with the smooth change in between (1e-12).
#[test]
fn yukawa_gaussian_is_continuous_at_branch_switch() {
    for &kappa in &[0.0, 1.0, 10.0, 100.0] {
        let s = 0.7;
        let r_switch = 1e-2 * s * 2f64.sqrt();
        let below = yukawa_gaussian(r_switch * (1.0 - 1e-9), kappa, s);
        let above = yukawa_gaussian(r_switch * (1.0 + 1e-9), kappa, s);
        assert!(
            rel_err(below, above) < 1e-12,
            "kappa={kappa}: {below} vs {above}"
        );
    }
}

/// No overflow for κs ≫ 1, where the Gaussian is much wider than the decay length and the
/// convolution tends to (4π/κ²) G_s(R) (1 + O((κs)⁻²)); far from the source (R ≫ s) it tends
/// to e^{κ²s²/2} e^{−κR}/R. Both limits to 1e-3 relative.
#[test]
fn yukawa_gaussian_limits_without_overflow() {
    let (kappa, s) = (400.0, 2.0);
    for &r in &[0.0, 1.0, 3.0, 6.0] {
        let got = yukawa_gaussian(r, kappa, s);
        let want = 4.0 * PI / (kappa * kappa) * gaussian_3d(r, s);
        assert!(
            got.is_finite() && rel_err(got, want) < 1e-3,
            "r={r}: {got} vs {want}"
        );
    }
    let (kappa, s) = (2.0f64, 0.1f64);
    let r = 5.0f64;
    let want = (kappa * kappa * s * s / 2.0).exp() * (-kappa * r).exp() / r;
    assert!(rel_err(yukawa_gaussian(r, kappa, s), want) < 1e-12);
    assert_eq!(yukawa_gaussian(2.0, 1.5, 0.0), (-3.0f64).exp() / 2.0);
}

/// Convolution with a unit-integral kernel keeps the integral: ∫ 4πR² (f∗G)(R) dR = 4π/κ²,
/// and the smoothed P_N fluence (δ included) still conserves energy,
/// ∫ fluence_gaussian d³τ / (4π) = 1/(1−α), for odd and even N (1e-9 relative).
#[test]
fn smoothing_preserves_integrals() {
    let gl = gauss_legendre(20);
    let (kappa, s) = (0.7, 0.8);
    let total = integrate(
        &|r| 4.0 * PI * r * r * yukawa_gaussian(r, kappa, s),
        0.0,
        80.0,
        &[],
        0.1,
        &gl,
    );
    assert!(rel_err(total, 4.0 * PI / (kappa * kappa)) < 1e-9, "{total}");
    for n in [1usize, 2, 5, 6] {
        let m = pn_point_source(n, 0.9, 0.2).unwrap();
        let t_max = 80.0 / m.kappa[0];
        let total = integrate(
            &|t| t * t * m.fluence_gaussian(t, 0.5),
            0.0,
            t_max,
            &[],
            0.05,
            &gl,
        );
        assert!(rel_err(total, 10.0) < 1e-9, "N={n}: {total}");
    }
}

/// A narrow Gaussian reproduces the point solution away from the source; world units scale
/// as φ = σ_t²/(4π) fluence_gaussian(σ_t r, σ_t s); CDA smooths like P_1.
#[test]
fn gaussian_fluence_consistency() {
    let m = pn_point_source(5, 0.9, 0.0).unwrap();
    for &tau in &[0.5, 1.0, 4.0] {
        let narrow = m.fluence_gaussian(tau, 1e-4);
        // Relative change (κ s)²/2 ≈ 5e-7 for the fastest mode κ ≈ 3.3.
        assert!(rel_err(narrow, m.fluence(tau)) < 1e-6, "tau={tau}");
    }
    let sigma_t = 8.0;
    let world = m.fluence_gaussian_world(0.1, 0.05, sigma_t);
    let want = sigma_t * sigma_t / (4.0 * PI) * m.fluence_gaussian(0.8, 0.4);
    assert!(rel_err(world, want) < 1e-14);
    let p1 = pn_point_source(1, 0.9, 0.4).unwrap();
    let cda = PointSourceModes::cda(0.9, 0.4).unwrap();
    assert!(
        rel_err(
            p1.fluence_gaussian(0.3, 0.2),
            cda.fluence_gaussian(0.3, 0.2)
        ) < 1e-12
    );
    // Finite at the centre.
    assert!(m.fluence_gaussian(0.0, 0.3).is_finite());
}
