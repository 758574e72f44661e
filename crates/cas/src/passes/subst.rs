//! Substitution: replace a symbolic index by an expression, or any node matching a
//! predicate by a replacement.

use crate::expr::Expr;

/// Replaces every free occurrence of the index `name` by `value` (sums over `name`
/// shadow it).
pub fn subst_index(e: &Expr, name: &str, value: &Expr) -> Expr {
    match e {
        Expr::Index(n) if n == name => value.clone(),
        Expr::Sum {
            index,
            lo,
            hi,
            body,
        } if index == name => Expr::Sum {
            index: index.clone(),
            lo: Box::new(subst_index(lo, name, value)),
            hi: hi.as_ref().map(|h| Box::new(subst_index(h, name, value))),
            body: body.clone(),
        },
        _ => e.map_children(&mut |c| subst_index(c, name, value)),
    }
}

/// Replaces, top-down, every node for which `f` returns `Some` (the replacement is not
/// visited again).
pub fn replace(e: &Expr, f: &dyn Fn(&Expr) -> Option<Expr>) -> Expr {
    match f(e) {
        Some(r) => r,
        None => e.map_children(&mut |c| replace(c, f)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substitutes_free_indices_only() {
        let l = Expr::index("l");
        let e = Expr::Add(vec![
            l.clone(),
            Expr::sum("l", Expr::Int(0), Some(l.clone()), l.clone()),
        ]);
        let r = subst_index(&e, "l", &Expr::Int(3));
        assert_eq!(
            r,
            Expr::Add(vec![
                Expr::Int(3),
                Expr::sum("l", Expr::Int(0), Some(Expr::Int(3)), l.clone()),
            ])
        );
        // Substituting an index that does not occur leaves the tree unchanged.
        assert_eq!(subst_index(&e, "m", &Expr::Int(1)), e);
    }

    #[test]
    fn replaces_matching_nodes() {
        let e = Expr::Mul(vec![Expr::sym("a"), Expr::sym("b")]);
        let r = replace(&e, &|n| (*n == Expr::sym("a")).then(|| Expr::int(2)));
        assert_eq!(r, Expr::Mul(vec![Expr::int(2), Expr::sym("b")]));
    }
}
