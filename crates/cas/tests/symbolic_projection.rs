//! End to end with symbolic indices: `∫ conj(Y_{l+1}^{m+1}) ω_x Y_l^m dω = −½ c_{l,m}`
//! (docs/design.md §2.1) obtained by the recursion and orthonormality passes alone.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use cas::passes::{
    collect::collect, normalize, orthonormality::orthonormality, sh_recursion, subst::subst_index,
};
use cas::{Axis, DirVar, Expr, ShKind};

fn shifted(i: &str, k: i64) -> Expr {
    Expr::Add(vec![Expr::index(i), Expr::Int(k)])
}

#[test]
fn projection_with_symbolic_indices() {
    let mut test = Expr::sh(
        ShKind::Complex,
        shifted("l", 1),
        shifted("m", 1),
        DirVar::Omega,
    );
    if let Expr::Sh { conj, .. } = &mut test {
        *conj = true;
    }
    let e = Expr::integral(
        DirVar::Omega,
        Expr::Mul(vec![
            test,
            Expr::DirComp(DirVar::Omega, Axis::X),
            Expr::sh(
                ShKind::Complex,
                Expr::index("l"),
                Expr::index("m"),
                DirVar::Omega,
            ),
        ]),
    );
    let e = normalize(&sh_recursion::apply_recursion(&e));
    let e = collect(&normalize(&orthonormality(&e)));
    // Only the f-term survives (the other deltas differ by constants and fold to 0).
    assert!(!e.any(&|n| matches!(n, Expr::Integral { .. } | Expr::Delta(..) | Expr::I)));
    let want = Expr::Mul(vec![
        Expr::rational(-1, 2),
        Expr::Func("c".into(), vec![Expr::index("l"), Expr::index("m")]),
    ]);
    // Compare values at concrete indices (both sides exact).
    for (l, m) in [(0i64, 0i64), (3, -2), (5, 4), (7, 0)] {
        let at = |x: &Expr| {
            let x = subst_index(x, "l", &Expr::Int(l));
            let x = subst_index(&x, "m", &Expr::Int(m));
            normalize(&sh_recursion::define_coefficients(&x))
        };
        assert_eq!(at(&e), at(&want), "(l, m) = ({l}, {m})");
    }
}
