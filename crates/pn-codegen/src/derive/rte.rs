//! The radiative transfer equation as an expression tree, and the truncated real
//! spherical-harmonic expansions substituted into it (docs/design.md §2).

use cas::passes::funk_hecke::phase_function;
use cas::{Axis, DirVar, Expr, FieldName, ShKind};

/// `L(x, dir)`, the radiance.
pub fn radiance(dir: DirVar) -> Expr {
    Expr::Func("L".into(), vec![Expr::pos_sym(), Expr::dir_sym(dir)])
}

/// `Q(x, ω)`, the emission.
pub fn emission() -> Expr {
    Expr::Func(
        "Q".into(),
        vec![Expr::pos_sym(), Expr::dir_sym(DirVar::Omega)],
    )
}

/// The three RTE terms moved to the left: transport `(ω·∇)L = Σ_d ω_d ∂_d L`,
/// collision `σ_t L` and scattering `−σ_s ∫ p(ω'·ω) L(x,ω') dω'`.
pub fn lhs_terms() -> [Expr; 3] {
    let transport = Expr::Add(
        Axis::ALL
            .iter()
            .map(|&a| {
                Expr::Mul(vec![
                    Expr::DirComp(DirVar::Omega, a),
                    radiance(DirVar::Omega).deriv(a),
                ])
            })
            .collect(),
    );
    let collision = Expr::Mul(vec![
        Expr::field(FieldName::SigmaT),
        radiance(DirVar::Omega),
    ]);
    let scattering = Expr::Mul(vec![
        Expr::int(-1),
        Expr::field(FieldName::SigmaS),
        Expr::integral(
            DirVar::OmegaPrime,
            Expr::Mul(vec![phase_function(), radiance(DirVar::OmegaPrime)]),
        ),
    ]);
    [transport, collision, scattering]
}

/// `Σ_{l'=0}^{hi} Σ_{m'=−l'}^{l'} name_{l'}^{m'}(x) Y_{l',m'}(dir)` in the real basis;
/// `hi = None` is the untruncated expansion.
pub fn expansion(name: &str, dir: DirVar, hi: Option<Expr>) -> Expr {
    let lp = Expr::index("l'");
    let mp = Expr::index("m'");
    Expr::sum(
        "l'",
        Expr::Int(0),
        hi,
        Expr::sum(
            "m'",
            Expr::Mul(vec![Expr::Int(-1), lp.clone()]),
            Some(lp.clone()),
            Expr::Mul(vec![
                Expr::coeff(name, ShKind::Real, lp.clone(), mp.clone()),
                Expr::sh(ShKind::Real, lp, mp, dir),
            ]),
        ),
    )
}
