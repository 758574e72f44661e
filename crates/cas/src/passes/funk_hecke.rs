//! The Funk–Hecke rule for a rotationally symmetric phase function (docs/design.md §2.1):
//! `∫ p(ω'·ω) Y_l^m(ω') dω' = λ_l p_l Y_l^m(ω)`, with `λ_l p_l` the field
//! [`FieldName::PhaseMoment`]. Holds for complex and real `Y` alike (the real ones are
//! combinations of complex ones of the same `l`).

use crate::expr::{DirVar, Expr, FieldName};

/// Name of the phase function in `Expr::Func`.
pub const PHASE: &str = "p";

/// `p(ω'·ω)` as an expression.
pub fn phase_function() -> Expr {
    Expr::Func(
        PHASE.into(),
        vec![
            Expr::dir_sym(DirVar::OmegaPrime),
            Expr::dir_sym(DirVar::Omega),
        ],
    )
}

/// Applies Funk–Hecke to every integral over ω' of `p(ω'·ω) · Y(ω')`.
pub fn funk_hecke(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut |n| match &n {
        Expr::Integral {
            var: DirVar::OmegaPrime,
            body,
        } => apply(body).unwrap_or(n),
        _ => n,
    })
}

fn apply(body: &Expr) -> Option<Expr> {
    let Expr::Mul(fs) = body else { return None };
    let [a, b] = fs.as_slice() else { return None };
    let (p, y) = if *a == phase_function() {
        (a, b)
    } else {
        (b, a)
    };
    if *p != phase_function() {
        return None;
    }
    match y {
        Expr::Sh {
            kind,
            l,
            m,
            dir: DirVar::OmegaPrime,
            conj,
        } => Some(Expr::Mul(vec![
            Expr::Field(FieldName::PhaseMoment(l.clone())),
            Expr::Sh {
                kind: *kind,
                l: l.clone(),
                m: m.clone(),
                dir: DirVar::Omega,
                conj: *conj,
            },
        ])),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::ShKind;

    #[test]
    fn scattering_integral_becomes_phase_moment() {
        let y = |d| Expr::sh(ShKind::Real, Expr::Int(2), Expr::Int(-1), d);
        let e = Expr::integral(
            DirVar::OmegaPrime,
            Expr::Mul(vec![phase_function(), y(DirVar::OmegaPrime)]),
        );
        assert_eq!(
            funk_hecke(&e),
            Expr::Mul(vec![
                Expr::Field(FieldName::PhaseMoment(Box::new(Expr::Int(2)))),
                y(DirVar::Omega)
            ])
        );
    }

    #[test]
    fn integral_over_omega_is_unchanged() {
        let e = Expr::integral(
            DirVar::Omega,
            Expr::Mul(vec![
                phase_function(),
                Expr::sh(ShKind::Real, Expr::Int(0), Expr::Int(0), DirVar::Omega),
            ]),
        );
        assert_eq!(funk_hecke(&e), e);
    }
}
