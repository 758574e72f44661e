//! Integer index arithmetic: linear forms `Σ k_i·index_i + c` and sign assumptions.
//!
//! Spherical-harmonic indices are integers built from symbolic indices (`l`, `m`, `l'`)
//! and integer constants with `+`, `−` and integer multiples. Bringing them into a
//! canonical linear form lets `l − (−m) + 1` and `l + m + 1` compare equal, and lets the
//! real↔complex conversion decide the sign of an index such as `m − 1` under an
//! assumption such as `m ≥ 1`.

use crate::expr::Expr;
use std::collections::BTreeMap;

/// `Σ coeffs[name]·name + constant`, with no zero coefficients stored.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Linear {
    /// Integer coefficient of each symbolic index.
    pub coeffs: BTreeMap<String, i64>,
    /// Constant term.
    pub constant: i64,
}

impl Linear {
    /// Reads an index expression (`Int`, `Index`, sums, integer multiples) as a linear form.
    pub fn from_expr(e: &Expr) -> Option<Linear> {
        match e {
            Expr::Int(n) => Some(Linear {
                coeffs: BTreeMap::new(),
                constant: *n,
            }),
            Expr::Index(name) => Some(Linear {
                coeffs: [(name.clone(), 1)].into_iter().collect(),
                constant: 0,
            }),
            Expr::Add(terms) => {
                let mut acc = Linear::default();
                for t in terms {
                    acc = acc.add(&Linear::from_expr(t)?);
                }
                Some(acc)
            }
            Expr::Mul(fs) => {
                let mut scale = 1i64;
                let mut lin: Option<Linear> = None;
                for f in fs {
                    match f {
                        Expr::Int(n) => scale = scale.checked_mul(*n)?,
                        Expr::Num(s) => scale = scale.checked_mul(s.as_integer()?)?,
                        other => {
                            if lin.is_some() {
                                return None;
                            }
                            lin = Some(Linear::from_expr(other)?);
                        }
                    }
                }
                Some(lin.unwrap_or(Linear::constant(1)).scale(scale))
            }
            _ => None,
        }
    }

    /// The constant `c`.
    pub fn constant(c: i64) -> Linear {
        Linear {
            coeffs: BTreeMap::new(),
            constant: c,
        }
    }

    /// Sum of two forms.
    pub fn add(&self, o: &Linear) -> Linear {
        let mut r = self.clone();
        for (k, v) in &o.coeffs {
            *r.coeffs.entry(k.clone()).or_insert(0) += v;
        }
        r.coeffs.retain(|_, v| *v != 0);
        r.constant += o.constant;
        r
    }

    /// Integer multiple.
    pub fn scale(&self, k: i64) -> Linear {
        let mut r = Linear {
            coeffs: self
                .coeffs
                .iter()
                .map(|(n, v)| (n.clone(), v * k))
                .collect(),
            constant: self.constant * k,
        };
        r.coeffs.retain(|_, v| *v != 0);
        r
    }

    /// The constant value, if no index occurs.
    pub fn as_constant(&self) -> Option<i64> {
        self.coeffs.is_empty().then_some(self.constant)
    }

    /// Canonical expression: index terms sorted by name, constant last.
    #[expect(
        clippy::expect_used,
        reason = "the empty and one-term cases return before, so terms has exactly one element here"
    )]
    pub fn to_expr(&self) -> Expr {
        let mut terms: Vec<Expr> = self
            .coeffs
            .iter()
            .map(|(n, k)| {
                if *k == 1 {
                    Expr::Index(n.clone())
                } else {
                    Expr::Mul(vec![Expr::Int(*k), Expr::Index(n.clone())])
                }
            })
            .collect();
        if self.constant != 0 || terms.is_empty() {
            terms.push(Expr::Int(self.constant));
        }
        if terms.len() == 1 {
            terms.pop().expect("one term")
        } else {
            Expr::Add(terms)
        }
    }
}

/// The sign of an integer quantity, as far as it is known.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sign {
    /// Known to be negative.
    Negative,
    /// Known to be zero.
    Zero,
    /// Known to be positive.
    Positive,
    /// Known to be ≥ 0 but possibly zero.
    NonNegative,
    /// Known to be ≤ 0 but possibly zero.
    NonPositive,
    /// Nothing known.
    Unknown,
}

/// Interval assumptions on symbolic indices (e.g. `m ≥ 1` for the case m > 0).
#[derive(Clone, Debug, Default)]
pub struct Assumptions {
    bounds: BTreeMap<String, (Option<i64>, Option<i64>)>,
}

impl Assumptions {
    /// No assumptions.
    pub fn none() -> Assumptions {
        Assumptions::default()
    }
    /// Adds `lo ≤ name ≤ hi` (either bound optional).
    pub fn with(mut self, name: &str, lo: Option<i64>, hi: Option<i64>) -> Assumptions {
        self.bounds.insert(name.into(), (lo, hi));
        self
    }

    /// Interval of a linear form.
    fn range(&self, lin: &Linear) -> (Option<i64>, Option<i64>) {
        let mut lo = Some(lin.constant);
        let mut hi = Some(lin.constant);
        for (name, k) in &lin.coeffs {
            let (blo, bhi) = self.bounds.get(name).copied().unwrap_or((None, None));
            let (tlo, thi) = if *k > 0 {
                (blo.map(|b| b * k), bhi.map(|b| b * k))
            } else {
                (bhi.map(|b| b * k), blo.map(|b| b * k))
            };
            lo = lo.zip(tlo).map(|(a, b)| a + b);
            hi = hi.zip(thi).map(|(a, b)| a + b);
        }
        (lo, hi)
    }

    /// The sign of an index expression under these assumptions.
    pub fn sign(&self, e: &Expr) -> Sign {
        let Some(lin) = Linear::from_expr(e) else {
            return Sign::Unknown;
        };
        match self.range(&lin) {
            (Some(lo), _) if lo > 0 => Sign::Positive,
            (_, Some(hi)) if hi < 0 => Sign::Negative,
            (Some(0), Some(0)) => Sign::Zero,
            (Some(0), _) => Sign::NonNegative,
            (_, Some(0)) => Sign::NonPositive,
            _ => Sign::Unknown,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_forms_are_canonical() {
        let l = Expr::index("l");
        let m = Expr::index("m");
        // l − (−m) + 1  ==  m + l + 1 in canonical order
        let a = Expr::Add(vec![
            l.clone(),
            Expr::Mul(vec![
                Expr::Int(-1),
                Expr::Mul(vec![Expr::Int(-1), m.clone()]),
            ]),
            Expr::Int(1),
        ]);
        let b = Expr::Add(vec![Expr::Int(1), m.clone(), l.clone()]);
        let la = Linear::from_expr(&a).unwrap();
        assert_eq!(la, Linear::from_expr(&b).unwrap());
        assert_eq!(la.to_expr(), Expr::Add(vec![l, m, Expr::Int(1)]));
    }

    #[test]
    fn signs_under_assumptions() {
        let a = Assumptions::none().with("m", Some(1), None);
        let m = Expr::index("m");
        let m_minus_1 = Expr::Add(vec![m.clone(), Expr::Int(-1)]);
        let minus_m = Expr::Mul(vec![Expr::Int(-1), m.clone()]);
        assert_eq!(a.sign(&m), Sign::Positive);
        assert_eq!(a.sign(&m_minus_1), Sign::NonNegative);
        assert_eq!(a.sign(&minus_m), Sign::Negative);
        assert_eq!(a.sign(&Expr::index("l")), Sign::Unknown);
        assert_eq!(Assumptions::none().sign(&Expr::Int(0)), Sign::Zero);
    }
}
