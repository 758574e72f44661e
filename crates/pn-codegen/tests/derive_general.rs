//! The general (symbolic l, m) equations instantiated at every concrete (l, m) equal the
//! expanded system, and the phase-function factors agree with quadrature.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_codegen::derive::general::{general_equations, instantiate, MCase};
use pn_codegen::derive::real_pn_system;
use pn_stencil::quadrature::{henyey_greenstein, phase_moments};

#[test]
fn general_form_instantiates_to_the_expanded_system() {
    let general = general_equations(false).expect("general derivation");
    assert_eq!(general.len(), 3);
    for order in [1usize, 2, 3, 6] {
        let sys = real_pn_system(order).unwrap();
        for eq in &sys.equations {
            let g = general.iter().find(|g| g.case == MCase::of(eq.m)).unwrap();
            let inst = instantiate(g, order, eq.l, eq.m).unwrap();
            // Exact equality of the canonical trees (same terms, same exact coefficients).
            assert_eq!(inst.lhs, eq.lhs, "P_{order} ({}, {})", eq.l, eq.m);
            assert_eq!(inst.rhs, eq.rhs);
        }
    }
}

#[test]
fn henyey_greenstein_moments_are_powers_of_g() {
    // λ_l p_l = 2π ∫ p_HG(μ) P_l(μ) dμ = g^l (docs/design.md §2.1). The HG integrand is smooth
    // (analytic for |g| < 1), so 400-point Gauss–Legendre converges to round-off; 1e-12
    // leaves room for the O(lmax) cancellation in the Legendre recurrence.
    for g in [-0.7, 0.0, 0.3, 0.5, 0.9] {
        let m = phase_moments(&|mu| henyey_greenstein(g, mu), 12, 400);
        for (l, v) in m.iter().enumerate() {
            let want = f64::powi(g, l as i32);
            assert!((v - want).abs() < 1e-12, "g={g} l={l}: {v} vs {want}");
        }
    }
}
