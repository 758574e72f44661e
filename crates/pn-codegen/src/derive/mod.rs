//! Derivation of the real-valued P_N equations from the RTE (docs/design.md §2).
//!
//! Contract used by the discretizer: [`PnSystem::equations`] holds one [`PnEquation`] per
//! (l, m) with l ≤ N, ordered by the moment index l(l+1)+m, each written as `lhs = rhs` with
//!
//! * `lhs` a sum of terms `c · ∂_d L_{l'}^{m'}` (as `Mul[Num(c), Deriv(d, Coeff L)]`),
//!   `σ_t · L_l^m` (`Mul[Field(SigmaT), Coeff L]`) and
//!   `−σ_s · λ_l p_l · L_l^m` (`Mul[Num(-1), Field(SigmaS), Field(PhaseMoment(Int l)), Coeff L]`);
//! * `rhs` the source coefficient `Q_l^m` (`Coeff Q`).
//!
//! The terms of `lhs` come in this order: derivatives (by axis x, y, z, then by the moment
//! index of `L_{l'}^{m'}`), collision, scattering. The same terms, structured, are in
//! [`PnEquation::terms`].
//!
//! Every equation is produced by [`pipeline::derive`] — projection of the RTE onto the real
//! basis function and the `cas` rewrite passes — and checked: no imaginary unit, basis
//! function, integral or sum may survive.

pub mod general;
pub mod pipeline;
pub mod render;
pub mod rte;
pub mod supplemental;
pub mod terms;

use cas::index::Assumptions;
use cas::{Axis, Expr, ShKind};

pub use terms::{Term, TermKind};

/// Highest order the derivation accepts (keeps exact arithmetic and run time bounded).
pub use pn_stencil::MAX_ORDER;

/// Errors of the derivation.
#[derive(Debug, thiserror::Error)]
pub enum DeriveError {
    /// Order 0 has no transport coupling (P_0 is not a transport approximation).
    #[error("order N = 0 is not supported: P_N needs N ≥ 1")]
    OrderZero,
    /// Too high an order.
    #[error("order N = {0} is too large (the maximum is {MAX_ORDER})")]
    OrderTooLarge(usize),
    /// A derived equation did not reduce to the canonical shape.
    #[error("equation (l={l}, m={m}) did not reduce to the canonical form: {reason}")]
    NotCanonical {
        /// Band.
        l: i64,
        /// Order.
        m: i64,
        /// What was left over.
        reason: String,
    },
}

/// One equation of the expanded real P_N system.
#[derive(Clone, Debug)]
pub struct PnEquation {
    /// Band of the equation (the moment it is the projection onto).
    pub l: i64,
    /// Order within the band.
    pub m: i64,
    /// Left-hand side (see module docs for the canonical shape).
    pub lhs: Expr,
    /// Right-hand side, `Q_l^m(x)`.
    pub rhs: Expr,
    /// The terms of `lhs = rhs` in structured form (source term last, on the right).
    pub terms: Vec<Term>,
}

/// The expanded real P_N system of one order N.
#[derive(Clone, Debug)]
pub struct PnSystem {
    /// The order N.
    pub order: usize,
    /// Equations ordered by l(l+1)+m.
    pub equations: Vec<PnEquation>,
}

/// Checks `order` against the supported range.
pub fn check_order(order: usize) -> Result<(), DeriveError> {
    match order {
        0 => Err(DeriveError::OrderZero),
        n if n > MAX_ORDER => Err(DeriveError::OrderTooLarge(n)),
        _ => Ok(()),
    }
}

/// The pipeline setup for a concrete test function `(l, m)` of order `order`.
pub fn concrete_setup(order: usize, l: i64, m: i64, record: bool) -> pipeline::Setup {
    pipeline::Setup {
        l: Expr::Int(l),
        m: Expr::Int(m),
        order: Some(Expr::Int(order as i64)),
        assume: Assumptions::none(),
        define_coefficients: true,
        record,
    }
}

/// Derives the equation for the test function `(l, m)` of P_N and brings it into the
/// canonical shape.
pub fn derive_equation(order: usize, l: i64, m: i64) -> Result<PnEquation, DeriveError> {
    let d = pipeline::derive(&concrete_setup(order, l, m, false));
    let terms = terms::extract(l, m, &d.lhs, &d.rhs)?;
    Ok(PnEquation {
        l,
        m,
        lhs: terms::lhs_expr(&terms),
        rhs: terms::rhs_expr(&terms),
        terms,
    })
}

/// The expanded real P_N system of order `order`, derived equation by equation.
pub fn real_pn_system(order: usize) -> Result<PnSystem, DeriveError> {
    check_order(order)?;
    use rayon::prelude::*;
    let n = order as i64;
    let lm: Vec<(i64, i64)> = (0..=n)
        .flat_map(|l| (-l..=l).map(move |m| (l, m)))
        .collect();
    // Equations are independent: derive them in parallel, keep the l(l+1)+m order.
    let equations = lm
        .par_iter()
        .map(|&(l, m)| derive_equation(order, l, m))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(PnSystem { order, equations })
}

/// Moment index `l(l+1)+m`.
pub fn moment_index(l: i64, m: i64) -> usize {
    (l * (l + 1) + m) as usize
}

/// The real-basis unknown `L_l^m` as in the contract.
pub fn moment(l: i64, m: i64) -> Expr {
    Expr::coeff("L", ShKind::Real, Expr::Int(l), Expr::Int(m))
}

/// Name of an axis for text output.
pub fn axis_name(a: Axis) -> &'static str {
    match a {
        Axis::X => "x",
        Axis::Y => "y",
        Axis::Z => "z",
    }
}
