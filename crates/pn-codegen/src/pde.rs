//! Input PDE systems for the discretizer: the derived P_N equations, their 2D reduction,
//! and scalar diffusion equations (CDA, and a diffusion equation with D given as a field)
//! written with the `cas` API.
//!
//! A [`PdeSystem`] is a list of unknowns (real-basis moments `L_l^m`) and one equation per
//! unknown; the equation of unknown `(l, m)` is *located* at that unknown's grid position
//! (docs/design.md §4: the discretizer works at a hypothetical equation location with the
//! equation's own staggered offset).

use cas::{Axis, Expr, FieldName, ShKind};

use crate::derive::PnSystem;
use pn_stencil::Dim;

/// One equation `lhs = rhs`, located at the position of unknown `(l, m)`.
#[derive(Clone, Debug, PartialEq)]
pub struct PdeEquation {
    /// Band of the unknown this equation is located at.
    pub l: i64,
    /// Order of the unknown this equation is located at.
    pub m: i64,
    /// Left-hand side.
    pub lhs: Expr,
    /// Right-hand side.
    pub rhs: Expr,
}

/// A square linear PDE system in the real-basis unknowns `L_l^m(x)`.
#[derive(Clone, Debug, PartialEq)]
pub struct PdeSystem {
    /// Short identifier, e.g. `p3` or `cda`.
    pub name: String,
    /// Dimension the equations are written for (2D: no ∂z terms).
    pub dim: Dim,
    /// Unknowns `(l, m)` in storage order.
    pub unknowns: Vec<(i64, i64)>,
    /// One equation per unknown, in the order of `unknowns`.
    pub equations: Vec<PdeEquation>,
}

impl PdeSystem {
    /// The 3D system of a derived P_N system (`name = "p<N>"`).
    pub fn from_pn(sys: &PnSystem) -> PdeSystem {
        PdeSystem {
            name: format!("p{}", sys.order),
            dim: Dim::Three,
            unknowns: sys.equations.iter().map(|e| (e.l, e.m)).collect(),
            equations: sys
                .equations
                .iter()
                .map(|e| PdeEquation {
                    l: e.l,
                    m: e.m,
                    lhs: e.lhs.clone(),
                    rhs: e.rhs.clone(),
                })
                .collect(),
        }
    }

    /// The P_N system of `sys` in dimension `dim` (3D: unchanged; 2D: [`PdeSystem::reduce_2d`]).
    pub fn pn(sys: &PnSystem, dim: Dim) -> PdeSystem {
        let full = PdeSystem::from_pn(sys);
        match dim {
            Dim::Three => full,
            Dim::Two => full.reduce_2d(),
        }
    }

    /// The 2D reduction of docs/design.md §3: for z-independent fields every moment with l+m odd
    /// vanishes (its basis function is odd under z → −z) and every ∂z term is zero. Drops
    /// those unknowns, their equations, and every term that contains a ∂z or a vanishing
    /// moment.
    pub fn reduce_2d(&self) -> PdeSystem {
        let keep = |l: i64, m: i64| (l + m).rem_euclid(2) == 0;
        PdeSystem {
            name: self.name.clone(),
            dim: Dim::Two,
            unknowns: self
                .unknowns
                .iter()
                .copied()
                .filter(|&(l, m)| keep(l, m))
                .collect(),
            equations: self
                .equations
                .iter()
                .filter(|e| keep(e.l, e.m))
                .map(|e| PdeEquation {
                    l: e.l,
                    m: e.m,
                    lhs: prune_2d(&e.lhs).unwrap_or_else(|| Expr::int(0)),
                    rhs: prune_2d(&e.rhs).unwrap_or_else(|| Expr::int(0)),
                })
                .collect(),
        }
    }
}

/// Removes ∂z subtrees and vanishing moments (l+m odd); `None` means the expression is zero.
fn prune_2d(e: &Expr) -> Option<Expr> {
    match e {
        Expr::Deriv(Axis::Z, _) => None,
        Expr::Deriv(a, c) => prune_2d(c).map(|c| Expr::Deriv(*a, Box::new(c))),
        Expr::Coeff { name, l, m, .. } if name == "L" => match (l.as_ref(), m.as_ref()) {
            (Expr::Int(l), Expr::Int(m)) if (l + m).rem_euclid(2) != 0 => None,
            _ => Some(e.clone()),
        },
        Expr::Add(ts) => {
            let ts: Vec<Expr> = ts.iter().filter_map(prune_2d).collect();
            if ts.is_empty() {
                None
            } else {
                Some(Expr::Add(ts))
            }
        }
        Expr::Mul(fs) => fs
            .iter()
            .map(prune_2d)
            .collect::<Option<Vec<Expr>>>()
            .map(Expr::Mul),
        // 0^x is treated as zero (only meaningful for x > 0).
        Expr::Pow(b, x) => prune_2d(b).map(|b| Expr::Pow(Box::new(b), x.clone())),
        _ => Some(e.clone()),
    }
}

/// The spatial axes of a dimension.
fn axes(dim: Dim) -> &'static [Axis] {
    match dim {
        Dim::Two => &[Axis::X, Axis::Y],
        Dim::Three => &[Axis::X, Axis::Y, Axis::Z],
    }
}

/// `−∇·(D ∇L_0^0) + σ_a L_0^0 = Q_0^0` for a diffusion coefficient expression `d`.
fn diffusion_equation(name: &str, dim: Dim, d: Expr) -> PdeSystem {
    let u = Expr::moment(0, 0);
    let div: Vec<Expr> = axes(dim)
        .iter()
        .map(|&a| Expr::mul(vec![d.clone(), u.clone().deriv(a)]).deriv(a))
        .collect();
    let lhs = Expr::add(vec![
        Expr::add(div).neg(),
        Expr::mul(vec![Expr::field(FieldName::SigmaA), u]),
    ]);
    PdeSystem {
        name: name.into(),
        dim,
        unknowns: vec![(0, 0)],
        equations: vec![PdeEquation {
            l: 0,
            m: 0,
            lhs,
            rhs: Expr::source(0, 0),
        }],
    }
}

/// The transport coefficient `σ_tr = σ_t − σ_s λ_1 p_1` (docs/design.md §2.2; `λ_1 p_1 = g` for
/// Henyey–Greenstein).
pub fn sigma_tr() -> Expr {
    Expr::add(vec![
        Expr::field(FieldName::SigmaT),
        Expr::mul(vec![
            Expr::field(FieldName::SigmaS),
            Expr::field(FieldName::PhaseMoment(Box::new(Expr::Int(1)))),
        ])
        .neg(),
    ])
}

/// Classical diffusion (docs/design.md §2.2) as an input PDE:
/// `−∇·(1/(3σ_tr) ∇L_0^0) + σ_a L_0^0 = Q_0^0`. Discretized, `D = 1/(3σ_tr)` is formed from
/// σ_t, σ_s and λ_1 p_1 requested at the half positions between neighbouring unknowns.
pub fn cda(dim: Dim) -> PdeSystem {
    let d = Expr::mul(vec![Expr::int(3), sigma_tr()]).recip();
    diffusion_equation("cda", dim, d)
}

/// `−∇·(D ∇L_0^0) + σ_a L_0^0 = Q_0^0` with `D` a field ([`FieldName::Diffusion`]), for
/// Picard steps of flux-limited diffusion.
pub fn diffusion(dim: Dim) -> PdeSystem {
    diffusion_equation("diffusion", dim, Expr::field(FieldName::Diffusion))
}

/// Whether `e` is the real-basis unknown `L_l^m` with concrete indices; returns them.
pub fn as_unknown(e: &Expr) -> Option<(i64, i64)> {
    match e {
        Expr::Coeff {
            name,
            kind: ShKind::Real,
            l,
            m,
        } if name == "L" => match (l.as_ref(), m.as_ref()) {
            (Expr::Int(l), Expr::Int(m)) => Some((*l, *m)),
            _ => None,
        },
        _ => None,
    }
}
