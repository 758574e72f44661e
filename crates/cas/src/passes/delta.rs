//! Collapsing sums over Kronecker deltas: `Σ_{i=lo}^{hi} δ_{i,v} f(i) = f(v)` if
//! `lo ≤ v ≤ hi`, else 0.
//!
//! The bound check is decided when `v` and the bounds are concrete; for symbolic `v` the
//! term is kept, with the convention that coefficients outside the summation range are
//! zero (for the P_N expansion: moments with l' > N, l' < 0 or |m'| > l' vanish).
//! A sum over `l'` whose body is a sum over `m'` collapses from the outside in: the
//! `δ_{l',v}` is pulled out of the inner sum first (see [`crate::passes::pull`]).

use crate::expr::Expr;
use crate::index::Linear;
use crate::passes::subst::subst_index;

/// Collapses every sum whose body (a product) has a delta on the summation index.
pub fn collapse_deltas(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut |n| match n {
        Expr::Sum {
            index,
            lo,
            hi,
            body,
        } => collapse(&index, &lo, hi.as_deref(), &body).unwrap_or(Expr::Sum {
            index,
            lo,
            hi,
            body,
        }),
        other => other,
    })
}

/// Uses a delta inside a product: `δ_{m,v} · f(m) = δ_{m,v} · f(v)` (for a symbolic index
/// `m` and `v` free of `m`).
pub fn delta_substitute(e: &Expr) -> Expr {
    delta_substitute_in(e, &|_| true)
}

/// [`delta_substitute`] restricted to the factors for which `only` holds (e.g. only the
/// signs `(−1)^m`, keeping moments and named coefficients symbolic so that terms combine).
pub fn delta_substitute_in(e: &Expr, only: &dyn Fn(&Expr) -> bool) -> Expr {
    e.rewrite_bottom_up(&mut |n| match n {
        Expr::Mul(fs) => {
            let found = fs.iter().enumerate().find_map(|(i, f)| match f {
                Expr::Delta(a, b) => match (&**a, &**b) {
                    (Expr::Index(name), v) | (v, Expr::Index(name)) if !v.contains_index(name) => {
                        Some((i, name.clone(), v.clone()))
                    }
                    _ => None,
                },
                _ => None,
            });
            match found {
                Some((i, name, v)) => Expr::Mul(
                    fs.iter()
                        .enumerate()
                        .map(|(j, f)| {
                            if i == j || !only(f) {
                                f.clone()
                            } else {
                                subst_index(f, &name, &v)
                            }
                        })
                        .collect(),
                ),
                None => Expr::Mul(fs),
            }
        }
        other => other,
    })
}

#[expect(
    clippy::expect_used,
    reason = "in the match arm for rest.len() == 1, so pop() returns the element"
)]
fn collapse(index: &str, lo: &Expr, hi: Option<&Expr>, body: &Expr) -> Option<Expr> {
    let fs: Vec<Expr> = match body {
        Expr::Mul(fs) => fs.clone(),
        e => vec![e.clone()],
    };
    let me = Expr::Index(index.into());
    let (pos, value) = fs.iter().enumerate().find_map(|(i, f)| match f {
        Expr::Delta(a, b) if **a == me && !b.contains_index(index) => Some((i, (**b).clone())),
        Expr::Delta(a, b) if **b == me && !a.contains_index(index) => Some((i, (**a).clone())),
        _ => None,
    })?;
    // Range check when everything is concrete.
    let c = |e: &Expr| Linear::from_expr(e).and_then(|l| l.as_constant());
    if let Some(v) = c(&value) {
        let below = c(lo).is_some_and(|lo| v < lo);
        let above = hi.and_then(c).is_some_and(|hi| v > hi);
        if below || above {
            return Some(Expr::int(0));
        }
    }
    let mut rest = fs;
    rest.remove(pos);
    let rest = match rest.len() {
        0 => Expr::int(1),
        1 => rest.pop().expect("one factor"),
        _ => Expr::Mul(rest),
    };
    Some(subst_index(&rest, index, &value))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::passes::fold::fold;

    #[test]
    fn collapses_in_range_and_drops_out_of_range() {
        let i = Expr::index("i");
        let s = |v: i64| {
            Expr::sum(
                "i",
                Expr::Int(0),
                Some(Expr::Int(3)),
                Expr::Mul(vec![
                    Expr::delta(i.clone(), Expr::Int(v)),
                    Expr::coeff("L", crate::ShKind::Real, i.clone(), Expr::Int(0)),
                ]),
            )
        };
        assert_eq!(
            fold(&collapse_deltas(&s(2))),
            Expr::coeff("L", crate::ShKind::Real, Expr::Int(2), Expr::Int(0))
        );
        assert_eq!(fold(&collapse_deltas(&s(4))), Expr::int(0));
    }

    #[test]
    fn delta_in_product_substitutes() {
        let m = Expr::index("m");
        let e = Expr::Mul(vec![
            Expr::delta(m.clone(), Expr::Int(1)),
            Expr::int(-1).pow(m.clone()),
            Expr::coeff(
                "L",
                crate::ShKind::Real,
                Expr::Int(2),
                Expr::Add(vec![m.clone(), Expr::Int(-1)]),
            ),
        ]);
        assert_eq!(
            fold(&delta_substitute(&e)),
            Expr::Mul(vec![
                Expr::int(-1),
                Expr::delta(m.clone(), Expr::Int(1)),
                Expr::coeff("L", crate::ShKind::Real, Expr::Int(2), Expr::Int(0)),
            ])
        );
    }

    #[test]
    fn sum_without_delta_is_unchanged() {
        let s = Expr::sum("i", Expr::Int(0), None, Expr::index("i"));
        assert_eq!(collapse_deltas(&s), s);
    }
}
