//! Pulling constant factors out: out of integrals (factors independent of the
//! integration variable), out of sums (factors without the summation index) and out of
//! spatial derivatives (factors independent of position).

use crate::expr::Expr;

/// Applies the three pull-out rules everywhere (bottom-up).
pub fn pull_factors(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut pull_node)
}

/// [`pull_factors`] on an owned tree (no copy).
pub fn pull_owned(e: Expr) -> Expr {
    e.rewrite_owned(&mut pull_node)
}

fn factors(e: Expr) -> Vec<Expr> {
    match e {
        Expr::Mul(fs) => fs,
        e => vec![e],
    }
}

#[expect(
    clippy::expect_used,
    reason = "in the match arm for fs.len() == 1, so pop() returns the element"
)]
fn product(mut fs: Vec<Expr>) -> Expr {
    match fs.len() {
        0 => Expr::int(1),
        1 => fs.pop().expect("one factor"),
        _ => Expr::Mul(fs),
    }
}

/// Splits `body` into (outside, inside) by `keep_inside`, rebuilds with `wrap`.
fn pull(body: Expr, keep_inside: &dyn Fn(&Expr) -> bool, wrap: &dyn Fn(Expr) -> Expr) -> Expr {
    let (inside, outside): (Vec<Expr>, Vec<Expr>) =
        factors(body).into_iter().partition(keep_inside);
    if outside.is_empty() {
        return wrap(product(inside));
    }
    let mut all = outside;
    all.push(wrap(product(inside)));
    Expr::Mul(all)
}

/// The pull-out rules at one node.
pub(crate) fn pull_node(e: Expr) -> Expr {
    match e {
        Expr::Integral { var, body } => pull(*body, &|f| f.depends_on_dir(var), &|b| {
            Expr::integral(var, b)
        }),
        Expr::Sum {
            index,
            lo,
            hi,
            body,
        } => {
            let idx = index.clone();
            pull(*body, &|f| f.contains_index(&idx), &|b| Expr::Sum {
                index: index.clone(),
                lo: lo.clone(),
                hi: hi.clone(),
                body: Box::new(b),
            })
        }
        Expr::Deriv(axis, body) => pull(*body, &|f| f.depends_on_position(), &|b| {
            Expr::Deriv(axis, Box::new(b))
        }),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::{Axis, DirVar, FieldName, ShKind};

    #[test]
    fn pulls_independent_factors_out() {
        let y = Expr::sh(ShKind::Real, Expr::Int(1), Expr::Int(0), DirVar::Omega);
        let l = Expr::moment(1, 0);
        let e = Expr::integral(
            DirVar::Omega,
            Expr::Mul(vec![Expr::int(2), l.clone(), y.clone()]),
        );
        assert_eq!(
            pull_factors(&e),
            Expr::Mul(vec![
                Expr::int(2),
                l.clone(),
                Expr::integral(DirVar::Omega, y.clone())
            ])
        );
        let d = Expr::Mul(vec![y.clone(), l.clone()]).deriv(Axis::Z);
        assert_eq!(
            pull_factors(&d),
            Expr::Mul(vec![y.clone(), l.clone().deriv(Axis::Z)])
        );
    }

    #[test]
    fn dependent_integrand_is_unchanged() {
        // Every factor depends on ω: nothing to pull.
        let e = Expr::integral(
            DirVar::Omega,
            Expr::Mul(vec![
                Expr::DirComp(DirVar::Omega, Axis::X),
                Expr::sh(ShKind::Real, Expr::Int(0), Expr::Int(0), DirVar::Omega),
            ]),
        );
        assert_eq!(pull_factors(&e), e);
        let s = Expr::sum(
            "i",
            Expr::Int(0),
            None,
            Expr::Mul(vec![Expr::field(FieldName::SigmaT), Expr::index("i")]),
        );
        assert_eq!(
            pull_factors(&s),
            Expr::Mul(vec![
                Expr::field(FieldName::SigmaT),
                Expr::sum("i", Expr::Int(0), None, Expr::index("i"))
            ])
        );
    }
}
