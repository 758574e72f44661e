//! Collecting like terms: `2·x + 3·x = 5·x`, `i·a·x − i·a·x = 0`.
//!
//! Terms of a sum are split into an exact complex coefficient (numbers and powers of `i`)
//! and the remaining factors; terms with equal remaining factors are added. The order of
//! first occurrence is kept. Coefficients whose real or imaginary part has unlike
//! radicands stay a sum of numbers (`(√2 + √3)·x`).

use crate::expr::Expr;
use crate::number::Surd;
use crate::passes::fold::{fold, fold_owned};

/// Exact complex coefficient as lists of surds with distinct radicands.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ComplexCoeff {
    /// Real part (sum of these).
    pub re: Vec<Surd>,
    /// Imaginary part (sum of these).
    pub im: Vec<Surd>,
}

#[expect(
    clippy::expect_used,
    reason = "position() matched the same radicand, which is the only case add_like refuses"
)]
fn add_into(v: &mut Vec<Surd>, s: Surd) {
    if s.is_zero() {
        return;
    }
    match v.iter_mut().position(|x| x.radicand == s.radicand) {
        Some(i) => {
            v[i] = v[i].add_like(&s).expect("same radicand");
            if v[i].is_zero() {
                v.remove(i);
            }
        }
        None => v.push(s),
    }
}

impl ComplexCoeff {
    /// True for 0.
    pub fn is_zero(&self) -> bool {
        self.re.is_empty() && self.im.is_empty()
    }
    /// Adds `other`.
    pub fn add(&mut self, other: &ComplexCoeff) {
        for s in &other.re {
            add_into(&mut self.re, *s);
        }
        for s in &other.im {
            add_into(&mut self.im, *s);
        }
    }
    /// As an expression (`None` for 1, so it can be omitted from a product).
    #[expect(
        clippy::expect_used,
        reason = "the one-term case is checked just before, so pop() returns it"
    )]
    pub fn to_expr(&self) -> Option<Expr> {
        if self.im.is_empty() && self.re.len() == 1 && self.re[0].is_one() {
            return None;
        }
        let mut ts: Vec<Expr> = self.re.iter().map(|s| Expr::Num(*s)).collect();
        ts.extend(self.im.iter().map(|s| {
            if s.is_one() {
                Expr::I
            } else {
                Expr::Mul(vec![Expr::Num(*s), Expr::I])
            }
        }));
        Some(if ts.len() == 1 {
            ts.pop().expect("one")
        } else {
            Expr::Add(ts)
        })
    }
}

/// Splits a folded term into its exact complex coefficient and the other factors.
pub fn split_coefficient(term: &Expr) -> (ComplexCoeff, Vec<Expr>) {
    let fs = match term {
        Expr::Mul(fs) => fs.clone(),
        t => vec![t.clone()],
    };
    let mut num = Surd::ONE;
    let mut imag = false;
    let mut rest = Vec::new();
    for f in fs {
        if let Some(s) = f.as_number() {
            num = num.mul(&s);
        } else if f == Expr::I {
            // fold leaves at most one i per product
            imag = !imag;
            if !imag {
                num = num.neg();
            }
        } else {
            rest.push(f);
        }
    }
    let mut c = ComplexCoeff::default();
    if imag {
        add_into(&mut c.im, num);
    } else {
        add_into(&mut c.re, num);
    }
    (c, rest)
}

/// Collects like terms in every sum (folds first).
pub fn collect(e: &Expr) -> Expr {
    fold_owned(fold(e).rewrite_owned(&mut |n| match n {
        // Index arithmetic (`l + 1`) is already canonical and must stay integral.
        Expr::Add(ts) if crate::index::Linear::from_expr(&Expr::Add(ts.clone())).is_some() => {
            Expr::Add(ts)
        }
        Expr::Add(ts) => collect_terms(ts),
        other => other,
    }))
}

#[expect(
    clippy::expect_used,
    reason = "each expect is in a match arm for len() == 1, so the element exists"
)]
fn collect_terms(ts: Vec<Expr>) -> Expr {
    let mut groups: Vec<(Vec<Expr>, ComplexCoeff)> = Vec::new();
    for t in ts {
        let (c, rest) = split_coefficient(&t);
        match groups.iter_mut().find(|(r, _)| *r == rest) {
            Some((_, acc)) => acc.add(&c),
            None => groups.push((rest, c)),
        }
    }
    let terms: Vec<Expr> = groups
        .into_iter()
        .filter(|(_, c)| !c.is_zero())
        .map(|(rest, c)| {
            let mut fs: Vec<Expr> = c.to_expr().into_iter().collect();
            fs.extend(rest);
            match fs.len() {
                0 => Expr::int(1),
                1 => fs.pop().expect("one"),
                _ => Expr::Mul(fs),
            }
        })
        .collect();
    match terms.len() {
        0 => Expr::int(0),
        1 => terms.into_iter().next().expect("one"),
        _ => Expr::Add(terms),
    }
}

/// Collects with respect to selected factors: terms of a sum whose factors satisfying
/// `key` are equal are combined into one term `(Σ coefficients) · key factors`, e.g.
/// `a·x + b·x → (a + b)·x` for `key = "is x"`. Folds and collects first.
#[expect(
    clippy::expect_used,
    reason = "each expect is in a match arm or branch for len() == 1, so the element exists"
)]
pub fn collect_wrt(e: &Expr, key: &dyn Fn(&Expr) -> bool) -> Expr {
    collect(e).rewrite_owned(&mut |n| match n {
        Expr::Add(ts) if crate::index::Linear::from_expr(&Expr::Add(ts.clone())).is_none() => {
            let mut groups: Vec<(Vec<Expr>, Vec<Expr>)> = Vec::new();
            for t in ts {
                let fs = match t {
                    Expr::Mul(fs) => fs,
                    t => vec![t],
                };
                let (k, rest): (Vec<Expr>, Vec<Expr>) = fs.into_iter().partition(|f| key(f));
                let coef = match rest.len() {
                    0 => Expr::int(1),
                    1 => rest.into_iter().next().expect("one"),
                    _ => Expr::Mul(rest),
                };
                match groups.iter_mut().find(|(gk, _)| *gk == k) {
                    Some((_, cs)) => cs.push(coef),
                    None => groups.push((k, vec![coef])),
                }
            }
            let terms: Vec<Expr> = groups
                .into_iter()
                .map(|(k, mut cs)| {
                    let c = if cs.len() == 1 {
                        cs.pop().expect("one")
                    } else {
                        Expr::Add(cs)
                    };
                    let mut fs = vec![c];
                    fs.extend(k);
                    fold(&Expr::Mul(fs))
                })
                .collect();
            if terms.len() == 1 {
                terms.into_iter().next().expect("one")
            } else {
                Expr::Add(terms)
            }
        }
        other => other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn like_terms_combine_and_cancel() {
        let x = Expr::sym("x");
        let y = Expr::sym("y");
        let e = Expr::Add(vec![
            Expr::Mul(vec![Expr::int(2), x.clone()]),
            Expr::Mul(vec![Expr::I, y.clone()]),
            Expr::Mul(vec![Expr::int(3), x.clone()]),
            Expr::Mul(vec![Expr::int(-1), Expr::I, y.clone()]),
        ]);
        assert_eq!(collect(&e), Expr::Mul(vec![Expr::int(5), x.clone()]));
    }

    #[test]
    fn index_sums_stay_integral() {
        let e = Expr::coeff(
            "L",
            crate::ShKind::Real,
            Expr::Add(vec![Expr::index("l"), Expr::Int(1)]),
            Expr::Int(0),
        );
        assert_eq!(collect(&e), e);
    }

    #[test]
    fn collects_with_respect_to_a_factor() {
        let (a, b, x, y) = (
            Expr::sym("a"),
            Expr::sym("b"),
            Expr::sym("x"),
            Expr::sym("y"),
        );
        let e = Expr::Add(vec![
            Expr::Mul(vec![a.clone(), x.clone()]),
            Expr::Mul(vec![b.clone(), x.clone()]),
            y.clone(),
        ]);
        let r = collect_wrt(&e, &|f| *f == x);
        // (a + b)·x + y, factors in canonical order
        let want = Expr::Add(vec![fold(&Expr::Mul(vec![Expr::Add(vec![a, b]), x])), y]);
        assert_eq!(r, want);
    }

    #[test]
    fn distinct_terms_are_unchanged() {
        let e = Expr::Add(vec![
            Expr::Mul(vec![Expr::int(2), Expr::sym("x")]),
            Expr::sym("y"),
        ]);
        assert_eq!(collect(&e), e);
    }
}
