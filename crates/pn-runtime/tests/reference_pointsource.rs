//! Semi-analytic P_N point-source solution (docs/design.md §7, tests/data/pointsource/).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_runtime::reference::{
    cda_point_source, grosjean, pn_point_source, transport_diffusion_mode, PointSourceModes,
    MAX_ORDER,
};
use std::f64::consts::PI;

fn assert_close(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got}, want {want} (|diff| = {:e} > {tol:e})",
        (got - want).abs()
    );
}

/// The rows of the reference README (α = 0.9, isotropic). The README prints 8 decimals, so
/// its rounding error is ≤ 5e-9; 1e-7 leaves room for nothing but that.
#[test]
fn matches_the_tabulated_reference_rows() {
    let p1 = pn_point_source(1, 0.9, 0.0).unwrap();
    assert_eq!(p1.kappa.len(), 1);
    assert_close(p1.kappa[0], 0.54772256, 1e-7, "P1 kappa");
    assert_close(p1.coeff[0], 3.0, 1e-7, "P1 C");
    assert_eq!(p1.delta_weight, 0.0);

    let p5 = pn_point_source(5, 0.9, 0.0).unwrap();
    let kappa = [0.52543038, 1.24087474, 3.29668816];
    let coeff = [2.52242486, 0.43993230, 6.27764284];
    assert_eq!(p5.kappa.len(), 3);
    for j in 0..3 {
        assert_close(p5.kappa[j], kappa[j], 1e-7, &format!("P5 kappa_{j}"));
        assert_close(p5.coeff[j], coeff[j], 1e-7, &format!("P5 C_{j}"));
    }
    assert_eq!(p5.delta_weight, 0.0);
}

/// P_1 is CDA with σ_tr = σ_t(1 − αg) (docs/design.md §2.2), for any albedo and g. Both sides are
/// closed forms evaluated in double precision: 1e-12 relative.
#[test]
fn p1_equals_cda_closed_form() {
    for &albedo in &[0.0, 0.3, 0.9, 0.999] {
        for &g in &[-0.7, 0.0, 0.5, 0.95] {
            let p1 = pn_point_source(1, albedo, g).unwrap();
            let cda = PointSourceModes::cda(albedo, g).unwrap();
            assert_close(p1.kappa[0], cda.kappa[0], 1e-12 * cda.kappa[0], "kappa");
            assert_close(p1.coeff[0], cda.coeff[0], 1e-12 * cda.coeff[0], "C");
            for &tau in &[0.01, 0.5, 1.0, 2.0, 4.0, 10.0] {
                let want = cda_point_source(tau, albedo, g);
                assert_close(p1.fluence(tau), want, 1e-12 * want, "P1 fluence vs CDA");
            }
        }
    }
    // docs/design.md §7's isotropic form 3 e^{−√(3(1−α))τ}/τ.
    for &tau in &[0.3, 1.0, 3.0] {
        let want = 3.0 * (-(3.0f64 * 0.1).sqrt() * tau).exp() / tau;
        assert_close(
            cda_point_source(tau, 0.9, 0.0),
            want,
            1e-14 * want,
            "CDA g=0",
        );
    }
}

/// P_2 by hand (isotropic, σ_t = 1). Modes: A v = νΣv gives 1 = (1−α)(3ν² − 4/5), so
/// κ² = 3/(1/(1−α) + 4/5). Jumps: d_1 + c(1−α) = 1 (row 0) and (2/5)d_1 − c/2 = 0 (row 2,
/// n_2 = P_2(0) = −1/2), so d_1 = 1/(1 + 4(1−α)/5), c = 4d_1/5. Amplitude a v_1 = d_1/2 and
/// v_0/v_1 = 1/((1−α)ν): C = d_1 κ²/(1−α), W = 4πc. This checks the even-N δ path against an
/// independent derivation (1e-12: closed forms in double precision).
#[test]
fn p2_matches_hand_derivation() {
    for &albedo in &[0.0, 0.5, 0.9, 0.99] {
        let m = pn_point_source(2, albedo, 0.0).unwrap();
        let s0 = 1.0 - albedo;
        let kappa2 = 3.0 / (1.0 / s0 + 0.8);
        let d1 = 1.0 / (1.0 + 0.8 * s0);
        assert_eq!(m.kappa.len(), 1);
        assert_close(m.kappa[0], kappa2.sqrt(), 1e-12, "P2 kappa");
        assert_close(m.coeff[0], d1 * kappa2 / s0, 1e-12 * m.coeff[0], "P2 C");
        assert_close(
            m.delta_weight,
            4.0 * PI * 0.8 * d1,
            1e-12,
            "P2 delta weight",
        );
    }
}

/// In an infinite medium every photon is absorbed: σ_a ∫φ d³x = 1, i.e.
/// Σ C_j/κ_j² + W/(4π) = 1/(1−α), for every N, α and g. The computation never imposes this,
/// so it checks κ, C and the even-N δ weight together. Tolerance 1e-9 relative: the modes
/// come from an SVD and a small LU solve (errors ~1e-14 · condition) and α = 0.99 amplifies
/// the slowest mode's weight by 1/κ² ≈ 30.
#[test]
fn conserves_energy_for_all_orders_albedos_and_g() {
    for n in 0..=15 {
        for &albedo in &[0.0, 0.3, 0.9, 0.99] {
            for &g in &[-0.5, 0.0, 0.3, 0.8] {
                let m = pn_point_source(n, albedo, g).unwrap();
                let want = 1.0 / (1.0 - albedo);
                assert_close(
                    m.integrated_fluence(),
                    want,
                    1e-9 * want,
                    &format!("energy N={n} alpha={albedo} g={g}"),
                );
                assert_eq!(m.kappa.len(), n.div_ceil(2), "number of modes N={n}");
                assert!(m.kappa.windows(2).all(|w| w[0] <= w[1]), "kappa ascending");
                assert!(m.kappa.iter().all(|k| *k > 0.0 && k.is_finite()));
                if n % 2 == 1 {
                    assert_eq!(m.delta_weight, 0.0);
                } else {
                    assert!(m.delta_weight > 0.0, "even N={n} carries a positive delta");
                }
            }
        }
    }
}

/// As N grows, the slowest P_N mode approaches the exact transport diffusion mode for
/// isotropic scattering, κ_0 from (α/(2κ)) ln((1+κ)/(1−κ)) = 1 and its residue coefficient
/// C_0 (closed_forms.rs). Measured: at α = 0.9 the κ error falls 2.2e-2, 1.3e-4, 8.6e-7, …
/// to 3e-16 at N = 15; at α = 0.5 from 0.27 to 1.7e-5. The assertions require monotone
/// convergence over odd N (until round-off at 1e-13) and bounds a factor ~10 above those.
#[test]
fn slowest_mode_converges_to_transport_diffusion_mode() {
    for &(albedo, kappa_tol, coeff_tol) in
        &[(0.5, 2e-4, 2e-2), (0.9, 1e-12, 1e-11), (0.99, 1e-13, 1e-12)]
    {
        let exact = transport_diffusion_mode(albedo).unwrap();
        let mut prev = f64::INFINITY;
        for n in (1..=15).step_by(2) {
            let m = pn_point_source(n, albedo, 0.0).unwrap();
            let err = (m.kappa[0] - exact.kappa).abs();
            assert!(
                err < prev || err < 1e-13,
                "alpha={albedo}: kappa error grew at N={n}: {err:e} after {prev:e}"
            );
            prev = err;
        }
        let m = pn_point_source(15, albedo, 0.0).unwrap();
        assert_close(
            m.kappa[0],
            exact.kappa,
            kappa_tol,
            "P15 kappa_0 vs transport",
        );
        assert_close(
            m.coeff[0],
            exact.coeff,
            coeff_tol * exact.coeff,
            "P15 C_0 vs transport",
        );
    }
    // The transport mode itself against the defining equation.
    let t = transport_diffusion_mode(0.9).unwrap();
    let lhs = 0.9 / (2.0 * t.kappa) * ((1.0 + t.kappa) / (1.0 - t.kappa)).ln();
    assert_close(lhs, 1.0, 1e-14, "transport dispersion relation");
}

/// Away from the source P_N converges in N (P_15 vs P_16 within 0.2% for τ ≥ 1; measured
/// 1.3e-3 at τ = 1) and Grosjean's approximation of transport is within a few percent of it
/// (measured 1.4% at τ = 1, 0.2% at 2, 0.9% at 4 for α = 0.9). Near the source P_N is not
/// converged (the uncollided e^{−τ}/τ² needs all orders), so τ < 1 is not asserted.
#[test]
fn high_order_pn_approaches_transport_away_from_the_source() {
    let p15 = pn_point_source(15, 0.9, 0.0).unwrap();
    let p16 = pn_point_source(16, 0.9, 0.0).unwrap();
    for &tau in &[1.0, 2.0, 4.0, 8.0] {
        let a = p15.fluence(tau);
        assert_close(
            p16.fluence(tau),
            a,
            2e-3 * a,
            &format!("P15 vs P16 at tau={tau}"),
        );
        assert_close(
            grosjean(tau, 0.9),
            a,
            3e-2 * a,
            &format!("Grosjean at tau={tau}"),
        );
    }
    // Even-N δ weight vanishes as N grows (transport has no δ at the source).
    let w: Vec<f64> = (1..=8)
        .map(|k| pn_point_source(2 * k, 0.9, 0.0).unwrap().delta_weight)
        .collect();
    assert!(
        w.windows(2).all(|x| x[1] < x[0]),
        "delta weights {w:?} decrease"
    );
}

/// Grosjean's closed form: for α = 0 it is the exact uncollided fluence e^{−τ}/τ².
#[test]
fn grosjean_closed_form() {
    for &tau in &[0.1f64, 1.0, 5.0] {
        let want = (-tau).exp() / (tau * tau);
        assert_close(grosjean(tau, 0.0), want, 1e-15 * want, "Grosjean alpha=0");
    }
    let (tau, a) = (2.0f64, 0.9f64);
    let lambda = (3.0 * (1.0 - a) / (2.0 - a)).sqrt();
    let want = (-tau).exp() / (tau * tau) + 3.0 * a / (2.0 - a) * (-lambda * tau).exp() / tau;
    assert_close(grosjean(tau, a), want, 1e-15, "Grosjean alpha=0.9");
}

/// Fluence in world units: φ = σ_t²/(4π) · fluence(σ_t r), and the absorbed power
/// σ_a ∫ φ d³x is the unit source power (composite Simpson over r, 1e-8 relative: the
/// integrand 4πr²φ is smooth, ∝ r at the origin, and the range covers 60 decay lengths).
#[test]
fn world_units_scale_with_sigma_t() {
    let m = pn_point_source(3, 0.9, 0.0).unwrap();
    let sigma_t = 8.0;
    assert_close(
        m.fluence_world(0.25, sigma_t),
        64.0 / (4.0 * PI) * m.fluence(2.0),
        1e-14,
        "world",
    );
    let r_max = 60.0 / (sigma_t * m.kappa[0]);
    let n = 20_000;
    let h = r_max / n as f64;
    let f = |r: f64| {
        if r == 0.0 {
            0.0
        } else {
            4.0 * PI * r * r * m.fluence_world(r, sigma_t)
        }
    };
    let mut sum = f(0.0) + f(r_max);
    for i in 1..n {
        sum += if i % 2 == 1 { 4.0 } else { 2.0 } * f(i as f64 * h);
    }
    let absorbed = sigma_t * 0.1 * sum * h / 3.0;
    assert_close(absorbed, 1.0, 1e-8, "absorbed power");
}

/// Bad input gets an error, not a panic.
#[test]
fn rejects_invalid_input() {
    assert!(pn_point_source(MAX_ORDER + 1, 0.9, 0.0).is_err());
    assert!(pn_point_source(3, 1.0, 0.0).is_err());
    assert!(pn_point_source(3, -0.1, 0.0).is_err());
    assert!(pn_point_source(3, f64::NAN, 0.0).is_err());
    assert!(pn_point_source(3, 0.9, 1.0).is_err());
    assert!(pn_point_source(3, 0.9, -1.0).is_err());
    assert!(PointSourceModes::cda(1.5, 0.0).is_err());
    assert!(transport_diffusion_mode(0.0).is_err());
    assert!(transport_diffusion_mode(1.0).is_err());
    let msg = pn_point_source(3, 1.0, 0.0).unwrap_err().to_string();
    assert!(msg.contains("albedo"), "{msg}");
    // The largest order still works.
    let m = pn_point_source(MAX_ORDER, 0.9, 0.3).unwrap();
    assert_close(m.integrated_fluence(), 10.0, 1e-8, "energy at MAX_ORDER");
}
