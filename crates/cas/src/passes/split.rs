//! Splitting and merging sums, integrals and derivatives over `+`.
//!
//! Splitting (linearity): `∫ (a + b) = ∫ a + ∫ b`, `Σ_i (a + b) = Σ_i a + Σ_i b`,
//! `∂_d (a + b) = ∂_d a + ∂_d b`, and moving sums to the outside:
//! `∫ Σ_i f = Σ_i ∫ f`, `∂_d Σ_i f = Σ_i ∂_d f`, `a · Σ_i f = Σ_i a f` (when `a` does not
//! contain `i`). Merging is the inverse: `∫ a + ∫ b = ∫ (a + b)`, `Σ_i a + Σ_i b = Σ_i (a + b)`.

use crate::expr::Expr;

/// Applies the linearity rules everywhere (bottom-up, to a fixed point per node).
pub fn split(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut split_node)
}

/// [`split`] on an owned tree (no copy).
pub fn split_owned(e: Expr) -> Expr {
    e.rewrite_owned(&mut split_node)
}

/// The splitting rules at one node.
pub(crate) fn split_node(e: Expr) -> Expr {
    match e {
        Expr::Integral { var, body } => match *body {
            Expr::Add(ts) => Expr::Add(
                ts.into_iter()
                    .map(|t| split_node(Expr::integral(var, t)))
                    .collect(),
            ),
            Expr::Sum {
                index,
                lo,
                hi,
                body,
            } => Expr::Sum {
                index,
                lo,
                hi,
                body: Box::new(split_node(Expr::integral(var, *body))),
            },
            b => Expr::integral(var, b),
        },
        Expr::Sum {
            index,
            lo,
            hi,
            body,
        } => match *body {
            Expr::Add(ts) => Expr::Add(
                ts.into_iter()
                    .map(|t| {
                        split_node(Expr::Sum {
                            index: index.clone(),
                            lo: lo.clone(),
                            hi: hi.clone(),
                            body: Box::new(t),
                        })
                    })
                    .collect(),
            ),
            b => Expr::Sum {
                index,
                lo,
                hi,
                body: Box::new(b),
            },
        },
        Expr::Deriv(axis, body) => match *body {
            Expr::Add(ts) => Expr::Add(
                ts.into_iter()
                    .map(|t| split_node(Expr::Deriv(axis, Box::new(t))))
                    .collect(),
            ),
            Expr::Sum {
                index,
                lo,
                hi,
                body,
            } => Expr::Sum {
                index,
                lo,
                hi,
                body: Box::new(split_node(Expr::Deriv(axis, body))),
            },
            b => Expr::Deriv(axis, Box::new(b)),
        },
        Expr::Mul(fs) => sums_out_of_product(fs),
        other => other,
    }
}

/// `a · Σ_i f · b = Σ_i (a f b)` for the first sum factor whose index does not occur in
/// the other factors.
fn sums_out_of_product(fs: Vec<Expr>) -> Expr {
    let pos = fs.iter().position(|f| match f {
        Expr::Sum { index, .. } => fs
            .iter()
            .filter(|g| !std::ptr::eq(*g, f))
            .all(|g| !g.contains_index(index)),
        _ => false,
    });
    let Some(pos) = pos else {
        return Expr::Mul(fs);
    };
    let mut fs = fs;
    let Expr::Sum {
        index,
        lo,
        hi,
        body,
    } = fs.remove(pos)
    else {
        unreachable!("position found a Sum")
    };
    fs.insert(pos, *body);
    Expr::Sum {
        index,
        lo,
        hi,
        body: Box::new(split_node(Expr::Mul(fs))),
    }
}

/// Merges integrals over the same variable that appear as terms of one sum.
#[expect(clippy::expect_used, reason = "the pop is under out.len() == 1")]
pub fn merge_integrals(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut |n| match n {
        Expr::Add(ts) => {
            let mut out: Vec<Expr> = Vec::new();
            for t in ts {
                if let Expr::Integral { var, body } = &t {
                    if let Some(Expr::Integral { body: b0, .. }) = out
                        .iter_mut()
                        .find(|o| matches!(o, Expr::Integral { var: v, .. } if v == var))
                    {
                        let prev = std::mem::replace(b0.as_mut(), Expr::Int(0));
                        **b0 = match prev {
                            Expr::Add(mut v) => {
                                v.push((**body).clone());
                                Expr::Add(v)
                            }
                            p => Expr::Add(vec![p, (**body).clone()]),
                        };
                        continue;
                    }
                }
                out.push(t);
            }
            if out.len() == 1 {
                out.pop().expect("one term")
            } else {
                Expr::Add(out)
            }
        }
        other => other,
    })
}

/// Merges sums with the same index and bounds that appear as terms of one sum:
/// `Σ_i a + Σ_i b = Σ_i (a + b)`.
#[expect(clippy::expect_used, reason = "the pop is under out.len() == 1")]
pub fn merge_sums(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut |n| match n {
        Expr::Add(ts) => {
            let mut out: Vec<Expr> = Vec::new();
            for t in ts {
                if let Expr::Sum {
                    index,
                    lo,
                    hi,
                    body,
                } = &t
                {
                    let same = out.iter_mut().find_map(|o| match o {
                        Expr::Sum {
                            index: i2,
                            lo: l2,
                            hi: h2,
                            body: b2,
                        } if i2 == index && l2 == lo && h2 == hi => Some(b2),
                        _ => None,
                    });
                    if let Some(b0) = same {
                        let prev = std::mem::replace(b0.as_mut(), Expr::Int(0));
                        **b0 = match prev {
                            Expr::Add(mut v) => {
                                v.push((**body).clone());
                                Expr::Add(v)
                            }
                            p => Expr::Add(vec![p, (**body).clone()]),
                        };
                        continue;
                    }
                }
                out.push(t);
            }
            if out.len() == 1 {
                out.pop().expect("one term")
            } else {
                Expr::Add(out)
            }
        }
        other => other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::{Axis, DirVar};

    #[test]
    fn integral_and_derivative_split_over_sums() {
        let (a, b) = (Expr::sym("a"), Expr::sym("b"));
        let e = Expr::integral(DirVar::Omega, Expr::Add(vec![a.clone(), b.clone()]));
        let s = split(&e);
        assert_eq!(
            s,
            Expr::Add(vec![
                Expr::integral(DirVar::Omega, a.clone()),
                Expr::integral(DirVar::Omega, b.clone())
            ])
        );
        assert_eq!(merge_integrals(&s), e);
        let d = Expr::Add(vec![a.clone(), b.clone()]).deriv(Axis::X);
        assert_eq!(
            split(&d),
            Expr::Add(vec![a.deriv(Axis::X), b.deriv(Axis::X)])
        );
    }

    #[test]
    fn sums_merge_and_split_back() {
        let i = Expr::index("i");
        let s = |b: Expr| Expr::sum("i", Expr::Int(0), Some(Expr::Int(3)), b);
        let e = Expr::Add(vec![s(i.clone()), s(Expr::sym("a"))]);
        let merged = merge_sums(&e);
        assert_eq!(merged, s(Expr::Add(vec![i.clone(), Expr::sym("a")])));
        assert_eq!(split(&merged), e);
        // Different bounds do not merge.
        let e2 = Expr::Add(vec![
            s(i.clone()),
            Expr::sum("i", Expr::Int(1), None, i.clone()),
        ]);
        assert_eq!(merge_sums(&e2), e2);
    }

    #[test]
    fn sums_move_outwards() {
        let i = Expr::index("i");
        let s = Expr::sum("i", Expr::Int(0), Some(Expr::Int(3)), i.clone());
        let e = Expr::Mul(vec![Expr::sym("a"), s]);
        assert_eq!(
            split(&e),
            Expr::sum(
                "i",
                Expr::Int(0),
                Some(Expr::Int(3)),
                Expr::Mul(vec![Expr::sym("a"), i.clone()])
            )
        );
        // A factor that contains the summation index blocks the move.
        let e = Expr::Mul(vec![
            i.clone(),
            Expr::sum("i", Expr::Int(0), None, i.clone()),
        ]);
        assert_eq!(split(&e), e);
    }
}
