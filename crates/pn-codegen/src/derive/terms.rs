//! Structured terms of a derived equation and the canonical `lhs`/`rhs` trees built from
//! them.

use cas::passes::collect::split_coefficient;
use cas::{Axis, Expr, FieldName, ShKind, Surd};

use super::DeriveError;

/// Kind of a term of `lhs = rhs`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum TermKind {
    /// `c ∂_d L_{l'}^{m'}`.
    Derivative,
    /// `σ_t L_l^m`.
    Collision,
    /// `−σ_s λ_l p_l L_l^m`.
    Scattering,
    /// `Q_l^m` (on the right-hand side).
    Source,
}

impl TermKind {
    /// Lower-case name used in JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            TermKind::Derivative => "derivative",
            TermKind::Collision => "collision",
            TermKind::Scattering => "scattering",
            TermKind::Source => "source",
        }
    }
}

/// One term: `coefficient · factor · [∂_axis] moment_{l}^{m}`.
#[derive(Clone, Debug, PartialEq)]
pub struct Term {
    /// Kind.
    pub kind: TermKind,
    /// Axis of a derivative term.
    pub axis: Option<Axis>,
    /// Band of the moment the term multiplies.
    pub l: i64,
    /// Order of the moment the term multiplies.
    pub m: i64,
    /// Exact coefficient.
    pub coefficient: Surd,
    /// Field factors (σ_t; σ_s and λ_l p_l), empty for derivatives and the source.
    pub factors: Vec<FieldName>,
}

fn concrete(e: &Expr) -> Option<i64> {
    match e {
        Expr::Int(n) => Some(*n),
        _ => None,
    }
}

fn moment_of(e: &Expr, name: &str) -> Option<(i64, i64)> {
    match e {
        Expr::Coeff {
            name: n,
            kind: ShKind::Real,
            l,
            m,
        } if n == name => Some((concrete(l)?, concrete(m)?)),
        _ => None,
    }
}

fn term_of(t: &Expr) -> Option<Term> {
    let (c, rest) = split_coefficient(t);
    if !c.im.is_empty() || c.re.len() != 1 {
        return None;
    }
    let coefficient = c.re[0];
    let (last, fields) = rest.split_last()?;
    let factors: Vec<FieldName> = fields
        .iter()
        .map(|f| match f {
            Expr::Field(n) => Some(n.clone()),
            _ => None,
        })
        .collect::<Option<_>>()?;
    match last {
        Expr::Deriv(axis, inner) if factors.is_empty() => {
            let (l, m) = moment_of(inner, "L")?;
            Some(Term {
                kind: TermKind::Derivative,
                axis: Some(*axis),
                l,
                m,
                coefficient,
                factors,
            })
        }
        e => {
            let (l, m) = moment_of(e, "L")?;
            let kind = match factors.as_slice() {
                [FieldName::SigmaT] => TermKind::Collision,
                [FieldName::SigmaS, FieldName::PhaseMoment(pl)] if concrete(pl) == Some(l) => {
                    TermKind::Scattering
                }
                _ => return None,
            };
            Some(Term {
                kind,
                axis: None,
                l,
                m,
                coefficient,
                factors,
            })
        }
    }
}

/// Reads the structured terms off a derived equation; fails unless every term has the
/// canonical shape (in particular, no imaginary unit is left).
pub fn extract(l: i64, m: i64, lhs: &Expr, rhs: &Expr) -> Result<Vec<Term>, DeriveError> {
    let err = |reason: String| DeriveError::NotCanonical { l, m, reason };
    if lhs.any(&|n| *n == Expr::I) || rhs.any(&|n| *n == Expr::I) {
        return Err(err("the imaginary unit did not cancel".into()));
    }
    let list = match lhs {
        Expr::Add(ts) => ts.clone(),
        t => vec![t.clone()],
    };
    let mut terms = Vec::with_capacity(list.len() + 1);
    for t in &list {
        terms.push(term_of(t).ok_or_else(|| {
            err(format!(
                "unexpected term {} ({t:?})",
                cas::print::latex::latex(t)
            ))
        })?);
    }
    let (ql, qm) = moment_of(rhs, "Q")
        .ok_or_else(|| err(format!("right-hand side {}", cas::print::latex::latex(rhs))))?;
    terms.sort_by_key(|t| (t.kind, t.axis, super::moment_index(t.l, t.m)));
    terms.push(Term {
        kind: TermKind::Source,
        axis: None,
        l: ql,
        m: qm,
        coefficient: Surd::ONE,
        factors: vec![],
    });
    Ok(terms)
}

#[expect(clippy::expect_used, reason = "the pop is under fs.len() == 1")]
fn term_expr(t: &Term) -> Expr {
    let name = if t.kind == TermKind::Source { "Q" } else { "L" };
    let mom = Expr::coeff(name, ShKind::Real, Expr::Int(t.l), Expr::Int(t.m));
    let mut fs = Vec::new();
    if !t.coefficient.is_one() || t.kind == TermKind::Derivative {
        fs.push(Expr::Num(t.coefficient));
    }
    fs.extend(t.factors.iter().cloned().map(Expr::Field));
    fs.push(match t.axis {
        Some(a) => mom.deriv(a),
        None => mom,
    });
    if fs.len() == 1 {
        fs.pop().expect("one")
    } else {
        Expr::Mul(fs)
    }
}

/// The canonical left-hand side (all terms but the source).
pub fn lhs_expr(terms: &[Term]) -> Expr {
    Expr::Add(
        terms
            .iter()
            .filter(|t| t.kind != TermKind::Source)
            .map(term_expr)
            .collect(),
    )
}

/// The canonical right-hand side (the source term).
pub fn rhs_expr(terms: &[Term]) -> Expr {
    terms
        .iter()
        .find(|t| t.kind == TermKind::Source)
        .map(term_expr)
        .unwrap_or_else(|| Expr::int(0))
}

/// Text name of a field factor (for JSON), e.g. `sigma_t`, `sigma_s*phase_moment_2`.
pub fn factor_text(t: &Term) -> String {
    if t.kind == TermKind::Source {
        return "1".into();
    }
    if t.factors.is_empty() {
        return "1".into();
    }
    t.factors
        .iter()
        .map(|f| match f {
            FieldName::SigmaT => "sigma_t".to_string(),
            FieldName::SigmaS => "sigma_s".to_string(),
            FieldName::SigmaA => "sigma_a".to_string(),
            FieldName::PhaseMoment(l) => format!("lambda_{0}*p_{0}", cas::print::latex::latex(l)),
            FieldName::Diffusion => "D".to_string(),
            FieldName::Named(n) => n.clone(),
        })
        .collect::<Vec<_>>()
        .join("*")
}
