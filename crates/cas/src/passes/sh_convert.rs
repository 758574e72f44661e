//! Conversion between the real spherical harmonics and the complex ones with the
//! Condon–Shortley phase (docs/design.md §2):
//!
//! ```text
//! m > 0:  Y_{l,m} = (1/√2) (Y_l^{−m} + (−1)^m Y_l^m)
//! m = 0:  Y_{l,0} = Y_l^0
//! m < 0:  Y_{l,m} = (i/√2) (Y_l^m − (−1)^m Y_l^{−m})
//! ```
//!
//! and its inverse, for k > 0: `Y_l^k = (−1)^k (Y_{l,k} + i Y_{l,−k})/√2`,
//! `Y_l^{−k} = (Y_{l,k} − i Y_{l,−k})/√2`, and `Y_l^0 = Y_{l,0}`.
//!
//! Which case applies depends on the sign of `m`. For concrete `m` it is known; for a
//! symbolic `m` it comes from [`Assumptions`]. When `m` may be zero or positive (e.g.
//! `m − 1` under `m ≥ 1`) the result is split with a Kronecker delta:
//! `δ_{m−1,0}·(case 0) + (1 − δ_{m−1,0})·(case > 0)`. With no usable information the
//! node is left unchanged.

use crate::expr::{DirVar, Expr, ShKind};
use crate::index::{Assumptions, Linear, Sign};

fn neg(m: &Expr) -> Expr {
    Expr::Mul(vec![Expr::Int(-1), m.clone()])
}
fn inv_sqrt2() -> Expr {
    Expr::rational(1, 2).sqrt()
}
fn sign_pow(m: &Expr) -> Expr {
    Expr::int(-1).pow(m.clone())
}

/// The index of the m = 0 branch. It is 0 there, possibly only under a δ (e.g. `m − 1`
/// under `δ_{m,1}`); keeping it symbolic, with a positive leading coefficient (`m − 1`
/// rather than `1 − m`), lets the term combine with the m ≠ 0 branches of the same moment.
fn zero_index(k: &Expr) -> Expr {
    match Linear::from_expr(k) {
        Some(lin) if lin.coeffs.values().next().is_some_and(|c| *c < 0) => lin.scale(-1).to_expr(),
        Some(lin) => lin.to_expr(),
        None => Expr::Int(0),
    }
}

/// Real `Y_{l,m}` in the complex basis, for `m` of known sign (`Positive`, `Zero` or
/// `Negative`).
fn real_in_complex(l: &Expr, m: &Expr, dir: DirVar, sign: Sign) -> Expr {
    let y = |mm: Expr| Expr::sh(ShKind::Complex, l.clone(), mm, dir);
    match sign {
        Sign::Positive => Expr::Mul(vec![
            inv_sqrt2(),
            Expr::Add(vec![y(neg(m)), Expr::Mul(vec![sign_pow(m), y(m.clone())])]),
        ]),
        Sign::Zero => y(zero_index(m)),
        Sign::Negative => Expr::Mul(vec![
            Expr::I,
            inv_sqrt2(),
            Expr::Add(vec![
                y(m.clone()),
                Expr::Mul(vec![Expr::int(-1), sign_pow(m), y(neg(m))]),
            ]),
        ]),
        _ => unreachable!("called with a definite sign"),
    }
}

/// Complex `Y_l^k` in the real basis, for `k` of known sign.
fn complex_in_real(l: &Expr, k: &Expr, dir: DirVar, sign: Sign) -> Expr {
    let r = |mm: Expr| Expr::sh(ShKind::Real, l.clone(), mm, dir);
    match sign {
        Sign::Positive => Expr::Mul(vec![
            sign_pow(k),
            inv_sqrt2(),
            Expr::Add(vec![r(k.clone()), Expr::Mul(vec![Expr::I, r(neg(k))])]),
        ]),
        Sign::Zero => r(zero_index(k)),
        Sign::Negative => Expr::Mul(vec![
            inv_sqrt2(),
            Expr::Add(vec![
                r(neg(k)),
                Expr::Mul(vec![Expr::int(-1), Expr::I, r(k.clone())]),
            ]),
        ]),
        _ => unreachable!("called with a definite sign"),
    }
}

/// Dispatches on the sign, splitting "zero or not" cases with a delta.
fn by_sign(m: &Expr, sign: Sign, f: &dyn Fn(Sign) -> Expr) -> Option<Expr> {
    let split = |other: Sign| {
        let d = Expr::delta(m.clone(), Expr::Int(0));
        Expr::Add(vec![
            Expr::Mul(vec![d.clone(), f(Sign::Zero)]),
            Expr::Mul(vec![
                Expr::Add(vec![Expr::int(1), Expr::Mul(vec![Expr::int(-1), d])]),
                f(other),
            ]),
        ])
    };
    match sign {
        Sign::Positive | Sign::Zero | Sign::Negative => Some(f(sign)),
        Sign::NonNegative => Some(split(Sign::Positive)),
        Sign::NonPositive => Some(split(Sign::Negative)),
        Sign::Unknown => None,
    }
}

/// Rewrites real `Y_{l,m}` whose sign of `m` is known (concrete, or from `assume`) into
/// complex `Y`s.
pub fn real_to_complex(e: &Expr, assume: &Assumptions) -> Expr {
    e.rewrite_bottom_up(&mut |n| match &n {
        Expr::Sh {
            kind: ShKind::Real,
            l,
            m,
            dir,
            ..
        } => by_sign(m, assume.sign(m), &|s| real_in_complex(l, m, *dir, s)).unwrap_or(n),
        _ => n,
    })
}

/// Rewrites complex `Y_l^k` (conjugated or not) with known sign of `k` into real `Y`s.
pub fn complex_to_real(e: &Expr, assume: &Assumptions) -> Expr {
    e.rewrite_bottom_up(&mut |n| match &n {
        Expr::Sh {
            kind: ShKind::Complex,
            l,
            m,
            dir,
            conj,
        } => match by_sign(m, assume.sign(m), &|s| complex_in_real(l, m, *dir, s)) {
            Some(r) if *conj => Expr::Conj(Box::new(r)),
            Some(r) => r,
            None => n,
        },
        _ => n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::passes::expand::expand;
    use crate::passes::fold::fold;

    fn simp(e: &Expr) -> Expr {
        fold(&expand(&fold(e)))
    }

    #[test]
    fn real_to_complex_and_back_is_identity() {
        for m in -3..=3 {
            let y = Expr::sh(ShKind::Real, Expr::Int(3), Expr::Int(m), DirVar::Omega);
            let c = simp(&real_to_complex(&y, &Assumptions::none()));
            assert!(!c.any(&|n| matches!(
                n,
                Expr::Sh {
                    kind: ShKind::Real,
                    ..
                }
            )));
            let back = simp(&complex_to_real(&c, &Assumptions::none()));
            let back = crate::passes::collect::collect(&back);
            assert_eq!(back, y, "m = {m}");
        }
    }

    #[test]
    fn unknown_sign_is_left_unchanged() {
        let y = Expr::sh(
            ShKind::Real,
            Expr::index("l"),
            Expr::index("m"),
            DirVar::Omega,
        );
        assert_eq!(real_to_complex(&y, &Assumptions::none()), y);
        // With m ≥ 1 it converts.
        let a = Assumptions::none().with("m", Some(1), None);
        assert_ne!(real_to_complex(&y, &a), y);
    }
}
