//! Orthonormality of the spherical harmonics on the unit sphere:
//!
//! ```text
//! ∫ Y_{l,m} Y_{l',m'} dω = δ_{l,l'} δ_{m,m'}                (real basis)
//! ∫ conj(Y_l^m) Y_{l'}^{m'} dω = δ_{l,l'} δ_{m,m'}          (complex basis)
//! ∫ Y_l^m Y_{l'}^{m'} dω = (−1)^m δ_{l,l'} δ_{−m,m'}        (from Y_l^{−m} = (−1)^m conj(Y_l^m))
//! ```
//!
//! Applies to integrals whose integrand is exactly two basis functions of the integration
//! variable (pull constant factors out first). Mixed real/complex pairs are left alone.

use crate::expr::{DirVar, Expr, ShKind};

/// Replaces every integral of a product of two basis functions by Kronecker deltas.
pub fn orthonormality(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut |n| match &n {
        Expr::Integral { var, body } => integrate_pair(*var, body).unwrap_or(n),
        _ => n,
    })
}

fn integrate_pair(var: DirVar, body: &Expr) -> Option<Expr> {
    let Expr::Mul(fs) = body else { return None };
    let [a, b] = fs.as_slice() else { return None };
    let parts = |e: &Expr| match e {
        Expr::Sh {
            kind,
            l,
            m,
            dir,
            conj,
        } if *dir == var => Some((*kind, (**l).clone(), (**m).clone(), *conj)),
        _ => None,
    };
    let (ka, la, ma, ca) = parts(a)?;
    let (kb, lb, mb, cb) = parts(b)?;
    let dl = Expr::delta(la, lb);
    match (ka, kb) {
        (ShKind::Real, ShKind::Real) => Some(Expr::Mul(vec![dl, Expr::delta(ma, mb)])),
        (ShKind::Complex, ShKind::Complex) if ca != cb => {
            Some(Expr::Mul(vec![dl, Expr::delta(ma, mb)]))
        }
        (ShKind::Complex, ShKind::Complex) => {
            // Both plain or both conjugated (the conjugate of a real result is itself).
            let neg_m = Expr::Mul(vec![Expr::Int(-1), ma.clone()]);
            Some(Expr::Mul(vec![
                Expr::int(-1).pow(ma),
                dl,
                Expr::delta(neg_m, mb),
            ]))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::passes::fold::fold;

    fn y(kind: ShKind, l: i64, m: i64) -> Expr {
        Expr::sh(kind, Expr::Int(l), Expr::Int(m), DirVar::Omega)
    }

    #[test]
    fn pairs_become_deltas() {
        let e = Expr::integral(
            DirVar::Omega,
            Expr::Mul(vec![y(ShKind::Real, 2, 1), y(ShKind::Real, 2, 1)]),
        );
        assert_eq!(fold(&orthonormality(&e)), Expr::int(1));
        let e = Expr::integral(
            DirVar::Omega,
            Expr::Mul(vec![y(ShKind::Real, 2, 1), y(ShKind::Real, 2, -1)]),
        );
        assert_eq!(fold(&orthonormality(&e)), Expr::int(0));
        // ∫ Y_1^1 Y_1^{-1} = (−1)^1 = −1
        let e = Expr::integral(
            DirVar::Omega,
            Expr::Mul(vec![y(ShKind::Complex, 1, 1), y(ShKind::Complex, 1, -1)]),
        );
        assert_eq!(fold(&orthonormality(&e)), Expr::int(-1));
    }

    #[test]
    fn three_factors_or_mixed_kinds_are_unchanged() {
        let e = Expr::integral(
            DirVar::Omega,
            Expr::Mul(vec![y(ShKind::Real, 1, 0), y(ShKind::Complex, 1, 0)]),
        );
        assert_eq!(orthonormality(&e), e);
        let e = Expr::integral(
            DirVar::Omega,
            Expr::Mul(vec![
                Expr::sym("a"),
                y(ShKind::Real, 1, 0),
                y(ShKind::Real, 1, 0),
            ]),
        );
        assert_eq!(orthonormality(&e), e);
    }
}
