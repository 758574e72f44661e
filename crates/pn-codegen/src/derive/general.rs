//! The general real P_N equations for symbolic `(l, m)`, in the three cases m < 0, m = 0,
//! m > 0 (the compact form of the paper's Eq. 5/6, derived, not transcribed).
//!
//! The same [`pipeline`] runs with symbolic indices `l`, `m` and sign
//! assumptions on `m`; the recursion coefficients stay named (`a_{l,m}` … `f_{l,m}`, docs/design.md
//! §2.1) and are brought into a canonical form (`e_{l,m} = c_{l,−m}`, `f_{l,m} = d_{l,−m}`,
//! `a` and `b` even in m) so that like terms combine. Where the real↔complex conversion needs
//! to know whether `m ± 1` is zero (m = ±1), the result carries Kronecker deltas `δ_{m,±1}`.
//!
//! Convention: moments `L_{l'}^{m'}` with `l' > N`, `l' < 0` or `|m'| > l'` are zero (the
//! P_N closure); [`instantiate`] applies it for a concrete order.

use cas::index::{Assumptions, Linear};
use cas::passes::{
    collect::{collect, collect_wrt},
    delta::delta_substitute_in,
    normalize,
    sh_recursion::define_coefficients,
    subst,
};
use cas::{Expr, ShKind};

use super::pipeline::{self, Step};
use super::{terms, DeriveError, PnEquation};

/// The three cases of the general form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MCase {
    /// m < 0.
    Negative,
    /// m = 0.
    Zero,
    /// m > 0.
    Positive,
}

impl MCase {
    /// All cases, in the order m < 0, m = 0, m > 0.
    pub const ALL: [MCase; 3] = [MCase::Negative, MCase::Zero, MCase::Positive];
    /// The case of a concrete m.
    pub fn of(m: i64) -> MCase {
        match m {
            m if m < 0 => MCase::Negative,
            0 => MCase::Zero,
            _ => MCase::Positive,
        }
    }
    /// LaTeX condition, e.g. `m > 0`.
    pub fn latex(self) -> &'static str {
        match self {
            MCase::Negative => "m < 0",
            MCase::Zero => "m = 0",
            MCase::Positive => "m > 0",
        }
    }
}

/// A general equation `lhs = rhs` for one case, with its derivation steps.
#[derive(Clone, Debug)]
pub struct GeneralEquation {
    /// The case.
    pub case: MCase,
    /// Left-hand side in symbolic `l`, `m`.
    pub lhs: Expr,
    /// Right-hand side.
    pub rhs: Expr,
    /// The recorded derivation.
    pub steps: Vec<Step>,
}

fn setup(case: MCase, record: bool) -> pipeline::Setup {
    let (m, assume) = match case {
        MCase::Negative => (
            Expr::index("m"),
            Assumptions::none()
                .with("m", None, Some(-1))
                .with("l", Some(1), None),
        ),
        MCase::Zero => (Expr::Int(0), Assumptions::none().with("l", Some(0), None)),
        MCase::Positive => (
            Expr::index("m"),
            Assumptions::none()
                .with("m", Some(1), None)
                .with("l", Some(1), None),
        ),
    };
    pipeline::Setup {
        l: Expr::index("l"),
        m,
        order: None,
        assume,
        define_coefficients: false,
        record,
    }
}

/// Canonical names of the recursion coefficients: `e_{l,m} → c_{l,−m}`, `f_{l,m} → d_{l,−m}`,
/// `a_{l,m}`, `b_{l,m}` with the sign of m chosen so the first index term is positive.
pub fn canonical_coefficients(e: &Expr) -> Expr {
    let neg = |m: &Expr| cas::passes::fold::fold(&Expr::Mul(vec![Expr::Int(-1), m.clone()]));
    let leading_negative = |m: &Expr| {
        Linear::from_expr(m).is_some_and(|lin| match lin.coeffs.values().next() {
            Some(k) => *k < 0,
            None => lin.constant < 0,
        })
    };
    subst::replace(e, &|n| match n {
        Expr::Func(name, args) if args.len() == 2 => {
            let (l, m) = (&args[0], &args[1]);
            let f = |nm: &str, mm: Expr| Some(Expr::Func(nm.into(), vec![l.clone(), mm]));
            match name.as_str() {
                "e" => f("c", neg(m)),
                "f" => f("d", neg(m)),
                "a" | "b" if leading_negative(m) => f(name, neg(m)),
                _ => None,
            }
        }
        _ => None,
    })
}

/// Derives the general equation of one case.
pub fn general_equation(case: MCase, record: bool) -> Result<GeneralEquation, DeriveError> {
    let mut d = pipeline::derive(&setup(case, record));
    let lhs = collect(&normalize(&canonical_coefficients(&d.lhs)));
    // Under δ_{m,±1} evaluate the signs (−1)^m; moments and named coefficients stay
    // symbolic so that the δ-terms combine with the general ones, then group by moment.
    let signs = |f: &Expr| matches!(f, Expr::Pow(b, _) if **b == Expr::int(-1));
    let lhs = collect(&normalize(&canonical_coefficients(&delta_substitute_in(
        &lhs, &signs,
    ))));
    let lhs = collect_wrt(&lhs, &|f| {
        matches!(f, Expr::Deriv(..) | Expr::Coeff { .. } | Expr::Field(_))
    });
    let rhs = collect(&d.rhs);
    if lhs.any(&|n| *n == Expr::I) {
        return Err(DeriveError::NotCanonical {
            l: -1,
            m: -1,
            reason: format!(
                "general form ({}): the imaginary unit did not cancel",
                case.latex()
            ),
        });
    }
    if record {
        d.steps.push(Step {
            title: "Canonical coefficients".into(),
            description: "Use $e_{l,m} = c_{l,-m}$, $f_{l,m} = d_{l,-m}$, $a_{l,-m} = a_{l,m}$, $b_{l,-m} = b_{l,m}$, evaluate factors next to a $\\delta_{m,\\pm 1}$ at $m = \\pm 1$ and collect like terms.".into(),
            lhs: lhs.clone(),
            rhs: rhs.clone(),
        });
    }
    Ok(GeneralEquation {
        case,
        lhs,
        rhs,
        steps: d.steps,
    })
}

/// All three general equations.
pub fn general_equations(record: bool) -> Result<Vec<GeneralEquation>, DeriveError> {
    MCase::ALL
        .iter()
        .map(|&c| general_equation(c, record))
        .collect()
}

/// Drops moments outside `0 ≤ l' ≤ order`, `|m'| ≤ l'` (concrete indices only).
fn apply_closure(e: &Expr, order: i64) -> Expr {
    subst::replace(e, &|n| match n {
        Expr::Coeff {
            name,
            kind: ShKind::Real,
            l,
            m,
        } if name == "L" => match (&**l, &**m) {
            (Expr::Int(l), Expr::Int(m)) if *l < 0 || *l > order || m.abs() > *l => {
                Some(Expr::int(0))
            }
            _ => None,
        },
        _ => None,
    })
}

/// The general equation of `m`'s case instantiated at concrete `(l, m)` for P_`order`:
/// substitute, evaluate coefficients and deltas, apply the closure, collect.
pub fn instantiate(
    g: &GeneralEquation,
    order: usize,
    l: i64,
    m: i64,
) -> Result<PnEquation, DeriveError> {
    let sub = |e: &Expr| {
        let e = subst::subst_index(e, "l", &Expr::Int(l));
        let e = subst::subst_index(&e, "m", &Expr::Int(m));
        let e = normalize(&define_coefficients(&e));
        collect(&normalize(&apply_closure(&e, order as i64)))
    };
    let (lhs, rhs) = (sub(&g.lhs), sub(&g.rhs));
    let t = terms::extract(l, m, &lhs, &rhs)?;
    Ok(PnEquation {
        l,
        m,
        lhs: terms::lhs_expr(&t),
        rhs: terms::rhs_expr(&t),
        terms: t,
    })
}
