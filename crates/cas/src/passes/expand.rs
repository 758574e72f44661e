//! Distributive expansion: products of sums become sums of products.

use crate::expr::Expr;

/// Expands every product over the sums among its factors (bottom-up), so that no `Mul`
/// has an `Add` factor afterwards. Nested sums are flattened.
pub fn expand(e: &Expr) -> Expr {
    expand_owned(e.clone())
}

/// [`expand`] on an owned tree (no copy).
pub fn expand_owned(e: Expr) -> Expr {
    e.rewrite_owned(&mut expand_node)
}

/// The distribution rule at one node.
pub(crate) fn expand_node(n: Expr) -> Expr {
    match n {
        Expr::Mul(fs) => distribute(fs),
        Expr::Add(ts) => flatten_add(ts),
        other => other,
    }
}

fn flatten_add(ts: Vec<Expr>) -> Expr {
    let mut out = Vec::new();
    for t in ts {
        match t {
            Expr::Add(inner) => out.extend(inner),
            t => out.push(t),
        }
    }
    Expr::Add(out)
}

fn distribute(fs: Vec<Expr>) -> Expr {
    if !fs.iter().any(|f| matches!(f, Expr::Add(_))) {
        return Expr::Mul(fs);
    }
    // Cartesian product of the factors' terms, in order.
    let mut acc: Vec<Vec<Expr>> = vec![vec![]];
    for f in fs {
        let terms = match f {
            Expr::Add(ts) => ts,
            f => vec![f],
        };
        let mut next = Vec::with_capacity(acc.len() * terms.len());
        for prefix in &acc {
            for t in &terms {
                let mut p = prefix.clone();
                match t {
                    Expr::Mul(inner) => p.extend(inner.iter().cloned()),
                    t => p.push(t.clone()),
                }
                next.push(p);
            }
        }
        acc = next;
    }
    Expr::Add(acc.into_iter().map(Expr::Mul).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distributes_products_over_sums() {
        let (a, b, c, d) = (
            Expr::sym("a"),
            Expr::sym("b"),
            Expr::sym("c"),
            Expr::sym("d"),
        );
        let e = Expr::Mul(vec![
            Expr::Add(vec![a.clone(), b.clone()]),
            Expr::Add(vec![c.clone(), d.clone()]),
        ]);
        let m = |x: &Expr, y: &Expr| Expr::Mul(vec![x.clone(), y.clone()]);
        assert_eq!(
            expand(&e),
            Expr::Add(vec![m(&a, &c), m(&a, &d), m(&b, &c), m(&b, &d)])
        );
    }

    #[test]
    fn product_without_sums_is_unchanged() {
        let e = Expr::Mul(vec![Expr::sym("a"), Expr::sym("b")]);
        assert_eq!(expand(&e), e);
    }
}
