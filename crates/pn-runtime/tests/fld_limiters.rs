//! Flux limiters: their two limits, |E| ≤ φ (R·F ≤ 1), spot values, the stable small-R branch
//! of Levermore–Pomraning, and parsing.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_runtime::fld::Limiter;

const FLD_LIMITERS: [Limiter; 6] = [
    Limiter::Sum,
    Limiter::Max,
    Limiter::Kershaw,
    Limiter::Larsen(2.0),
    Limiter::Larsen(5.0),
    Limiter::LevermorePomraning,
];

/// Knudsen numbers from 1e-8 to 1e8, 20 per decade.
fn log_grid() -> impl Iterator<Item = f64> {
    (-160..=160).map(|e| 10f64.powf(e as f64 / 20.0))
}

#[test]
fn thick_limit_is_classical_diffusion() {
    // F(R) = 1/3 − O(R) (sum, Kershaw) or − O(R²) (others): at R = 1e-8 every limiter is
    // within 1e-8 of 1/3 (sum: 1/(3+R) = 1/3 − R/9 + …, the slowest).
    for lim in FLD_LIMITERS.into_iter().chain([Limiter::Cda]) {
        assert!(
            (lim.eval(0.0) - 1.0 / 3.0).abs() < 1e-15,
            "{lim}: F(0) = {}",
            lim.eval(0.0)
        );
        let f = lim.eval(1e-8);
        assert!((f - 1.0 / 3.0).abs() < 1e-8, "{lim}: F(1e-8) = {f}");
    }
}

#[test]
fn thin_limit_bounds_the_flux() {
    // R·F(R) = 1 − O(1/R) (sum: 3/R, Kershaw: 1.5/R, LP: 1/R) or faster, so at R = 1e8 it is
    // within 1e-7 of 1; at R = 1e300 it must still be finite and ≈ 1 (no overflow).
    for lim in FLD_LIMITERS {
        for r in [1e8, 1e300] {
            let rf = r * lim.eval(r);
            assert!((rf - 1.0).abs() < 1e-7, "{lim}: R·F(R) = {rf} at R = {r}");
        }
    }
    // CDA does not limit: R·F grows without bound.
    assert!((Limiter::Cda.eval(1e8) * 1e8 - 1e8 / 3.0).abs() < 1e-6);
}

#[test]
fn limiters_bound_flux_by_fluence_everywhere() {
    // |E|/φ = R·F(R) must not exceed 1, F must lie in (0, 1/3] and be non-increasing.
    for lim in FLD_LIMITERS {
        let mut prev = f64::INFINITY;
        for r in log_grid() {
            let f = lim.eval(r);
            assert!(
                f.is_finite() && f > 0.0 && f <= 1.0 / 3.0 + 1e-16,
                "{lim}: F({r}) = {f}"
            );
            assert!(r * f <= 1.0 + 1e-15, "{lim}: R·F = {} at R = {r}", r * f);
            assert!(f <= prev + 1e-16, "{lim}: F increases at R = {r}");
            prev = f;
        }
    }
}

#[test]
fn spot_values() {
    let cases = [
        (Limiter::Sum, 1.0, 0.25),
        (Limiter::Max, 2.0, 1.0 / 3.0),
        (Limiter::Max, 6.0, 1.0 / 6.0),
        (Limiter::Kershaw, 2.0, 0.25),    // 2/(3 + √(9+16))
        (Limiter::Larsen(2.0), 4.0, 0.2), // 1/√(9+16)
        (Limiter::Larsen(3.0), 3.0, 1.0 / 54f64.cbrt()),
        (Limiter::Larsen(1.0), 1.0, 0.25), // Larsen-1 is the sum limiter
    ];
    for (lim, r, want) in cases {
        let got = lim.eval(r);
        assert!(
            (got - want).abs() < 1e-15,
            "{lim}: F({r}) = {got}, want {want}"
        );
    }
    // LP against coth written independently as (e^{2R}+1)/(e^{2R}−1), no cancellation at R ≥ 1.
    for r in [1.0f64, 2.0, 5.0, 20.0] {
        let e = (2.0 * r).exp();
        let want = ((e + 1.0) / (e - 1.0) - 1.0 / r) / r;
        let got = Limiter::LevermorePomraning.eval(r);
        assert!((got - want).abs() < 1e-15, "LP F({r}) = {got}, want {want}");
    }
}

/// `(coth R − 1/R)/R` from six terms of the Laurent series `Σ 2^{2n} B_{2n} R^{2n−1}/(2n)!`
/// (B₂ = 1/6, B₄ = −1/30, B₆ = 1/42, B₈ = −1/30, B₁₀ = 5/66, B₁₂ = −691/2730).
fn lp_reference(r: f64) -> f64 {
    let terms = [
        1.0 / 3.0,
        -1.0 / 45.0,
        2.0 / 945.0,
        -1.0 / 4725.0,
        2.0 / 93555.0,
        -1382.0 / 638512875.0,
    ];
    terms
        .iter()
        .enumerate()
        .map(|(i, c)| c * r.powi(2 * i as i32))
        .sum()
}

#[test]
fn levermore_pomraning_is_stable_near_zero() {
    let lp = Limiter::LevermorePomraning;
    for r in [0.0, 5e-324, 1e-300, 1e-100, 1e-10, 1e-5, 1e-3] {
        let f = lp.eval(r);
        assert!(f.is_finite(), "LP F({r}) = {f}");
        assert!((f - lp_reference(r)).abs() < 1e-15, "LP F({r}) = {f}");
    }
    // Both branches against the 6-term series, accurate to < 1e-15 for R ≤ 0.2 (first
    // omitted term 2.2e-7·R¹²). The closed-form branch loses ~log10(3/R²) digits, so 1e-13.
    for i in 1..=40 {
        let r = 0.005 * i as f64;
        let f = lp.eval(r);
        assert!(
            (f - lp_reference(r)).abs() < 1e-13,
            "LP F({r}) = {f}, series {}",
            lp_reference(r)
        );
    }
}

#[test]
fn parse_limiter_names() {
    let cases = [
        ("lp", Limiter::LevermorePomraning),
        ("LP", Limiter::LevermorePomraning),
        ("sum", Limiter::Sum),
        ("max", Limiter::Max),
        ("kershaw", Limiter::Kershaw),
        ("larsen2", Limiter::Larsen(2.0)),
        ("larsen3.5", Limiter::Larsen(3.5)),
        ("cda", Limiter::Cda),
    ];
    for (name, want) in cases {
        let got: Limiter = name.parse().unwrap();
        assert_eq!(got, want, "{name}");
        // Display round-trips.
        assert_eq!(got.to_string().parse::<Limiter>().unwrap(), got);
    }
    for bad in [
        "minmod",
        "",
        "larsen",
        "larsen-1",
        "larsen0",
        "larsenx",
        "larsennan",
    ] {
        let err = bad.parse::<Limiter>().unwrap_err().to_string();
        assert!(err.contains(bad) || err.contains("Larsen"), "{bad}: {err}");
    }
    let err = "minmod".parse::<Limiter>().unwrap_err().to_string();
    assert!(err.contains("kershaw") && err.contains("larsen2"), "{err}");
}
