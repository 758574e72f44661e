//! The derived real P_N system against numerical quadrature (docs/design.md §2.3) and the P_1
//! hand-check (docs/design.md §2.2).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use cas::{Axis, Expr, FieldName};
use pn_codegen::derive::{moment_index, real_pn_system, Term, TermKind};
use pn_stencil::quadrature::{moment_count, transport_matrices};

/// Dense transport matrices read off the derived equations.
fn derived_matrices(order: usize) -> [Vec<Vec<f64>>; 3] {
    let sys = real_pn_system(order).expect("derivation succeeds");
    let n = moment_count(order);
    let mut out: [Vec<Vec<f64>>; 3] = std::array::from_fn(|_| vec![vec![0.0; n]; n]);
    for eq in &sys.equations {
        for t in eq.terms.iter().filter(|t| t.kind == TermKind::Derivative) {
            let a = t.axis.expect("derivative has an axis").index();
            out[a][moment_index(eq.l, eq.m)][moment_index(t.l, t.m)] += t.coefficient.to_f64();
        }
    }
    out
}

#[test]
fn transport_matches_quadrature_n1_to_12() {
    // Quadrature is exact for these polynomial degrees; the only error is f64 rounding in
    // sums of O(N²) products of O(1) values, so 1e-12 is a safe bound (observed ~1e-15).
    for order in 1..=12 {
        let got = derived_matrices(order);
        let want = transport_matrices(order);
        let mut worst = 0.0f64;
        for d in 0..3 {
            for (gr, wr) in got[d].iter().zip(&want[d]) {
                for (g, w) in gr.iter().zip(wr) {
                    worst = worst.max((g - w).abs());
                }
            }
        }
        eprintln!("P_{order}: max |derived - quadrature| = {worst:.1e}");
        assert!(
            worst < 1e-12,
            "P_{order}: max |derived − quadrature| = {worst:e}"
        );
    }
}

#[test]
fn collision_and_scattering_are_diagonal() {
    for order in [1, 2, 5] {
        let sys = real_pn_system(order).unwrap();
        assert_eq!(sys.equations.len(), moment_count(order));
        for (k, eq) in sys.equations.iter().enumerate() {
            assert_eq!(moment_index(eq.l, eq.m), k, "ordering by l(l+1)+m");
            let col: Vec<&Term> = eq
                .terms
                .iter()
                .filter(|t| t.kind == TermKind::Collision)
                .collect();
            let sca: Vec<&Term> = eq
                .terms
                .iter()
                .filter(|t| t.kind == TermKind::Scattering)
                .collect();
            assert_eq!(col.len(), 1);
            assert_eq!(sca.len(), 1);
            assert_eq!(
                (col[0].l, col[0].m, col[0].coefficient.to_f64()),
                (eq.l, eq.m, 1.0)
            );
            assert_eq!(
                (sca[0].l, sca[0].m, sca[0].coefficient.to_f64()),
                (eq.l, eq.m, -1.0)
            );
            assert_eq!(eq.rhs, Expr::source(eq.l, eq.m));
        }
    }
}

#[test]
fn p1_matches_the_hand_check() {
    // docs/design.md §2.2:
    //   (1/√3)(∂x L_1^1 + ∂y L_1^{-1} + ∂z L_1^0) + σ_t L_0^0 − σ_s λ_0 p_0 L_0^0 = Q_0^0
    //   (1/√3) ∂x L_0^0 + (σ_t − σ_s λ_1 p_1) L_1^1 = Q_1^1   (y ↔ L_1^{-1}, z ↔ L_1^0)
    let s3 = Expr::Num(cas::Surd::sqrt_ratio(1, 3).unwrap());
    let d = |l, m, a| Expr::Mul(vec![s3.clone(), Expr::moment(l, m).deriv(a)]);
    let col = |l, m| Expr::Mul(vec![Expr::field(FieldName::SigmaT), Expr::moment(l, m)]);
    let sca = |l: i64, m| {
        Expr::Mul(vec![
            Expr::int(-1),
            Expr::field(FieldName::SigmaS),
            Expr::field(FieldName::PhaseMoment(Box::new(Expr::Int(l)))),
            Expr::moment(l, m),
        ])
    };
    let sys = real_pn_system(1).unwrap();
    let want = [
        (
            0,
            0,
            vec![
                d(1, 1, Axis::X),
                d(1, -1, Axis::Y),
                d(1, 0, Axis::Z),
                col(0, 0),
                sca(0, 0),
            ],
        ),
        (1, -1, vec![d(0, 0, Axis::Y), col(1, -1), sca(1, -1)]),
        (1, 0, vec![d(0, 0, Axis::Z), col(1, 0), sca(1, 0)]),
        (1, 1, vec![d(0, 0, Axis::X), col(1, 1), sca(1, 1)]),
    ];
    for (eq, (l, m, terms)) in sys.equations.iter().zip(want) {
        assert_eq!((eq.l, eq.m), (l, m));
        assert_eq!(eq.lhs, Expr::Add(terms), "P_1 equation ({l},{m})");
        assert_eq!(eq.rhs, Expr::source(l, m));
    }
}

#[test]
fn bad_orders_are_rejected() {
    assert!(real_pn_system(0).is_err());
    assert!(real_pn_system(100_000).is_err());
}

#[test]
#[ignore = "timing; run with --ignored --nocapture"]
fn time_order_30() {
    let t = std::time::Instant::now();
    let sys = real_pn_system(30).unwrap();
    eprintln!(
        "P_30: {} equations in {:?}",
        sys.equations.len(),
        t.elapsed()
    );
}

#[test]
fn high_order_rows_are_exact_and_match_quadrature() {
    // Order 60 (the CLI maximum): exact surd arithmetic must not overflow, and single rows
    // must still agree with quadrature. Tolerance 1e-11: the f64 recurrences for P_60^m
    // lose a few digits (observed ≲1e-13).
    use pn_codegen::derive::derive_equation;
    use pn_stencil::quadrature::{real_sh, SphereQuadrature};
    let order = 60usize;
    let q = SphereQuadrature::exact_for_degree(2 * order + 1);
    for (l, m) in [(60i64, 59i64), (60, -60), (59, 0), (45, -1), (1, 1)] {
        let eq = derive_equation(order, l, m).unwrap();
        let y: Vec<f64> = q
            .points
            .iter()
            .map(|(_, mu, phi)| real_sh(l as usize, m, *mu, *phi))
            .collect();
        for lp in [l - 1, l + 1] {
            if lp < 0 || lp > order as i64 {
                continue;
            }
            for mp in -lp..=lp {
                let yp: Vec<f64> = q
                    .points
                    .iter()
                    .map(|(_, mu, phi)| real_sh(lp as usize, mp, *mu, *phi))
                    .collect();
                for d in 0..3 {
                    let want: f64 = (0..y.len())
                        .map(|k| q.weights[k] * q.points[k].0[d] * y[k] * yp[k])
                        .sum();
                    let got: f64 = eq
                        .terms
                        .iter()
                        .filter(|t| {
                            t.kind == TermKind::Derivative
                                && t.axis.unwrap().index() == d
                                && (t.l, t.m) == (lp, mp)
                        })
                        .map(|t| t.coefficient.to_f64())
                        .sum();
                    assert!(
                        (got - want).abs() < 1e-11,
                        "({l},{m}) d={d} ({lp},{mp}): {got} vs {want}"
                    );
                }
            }
        }
    }
}
