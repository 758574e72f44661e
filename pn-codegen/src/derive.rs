//! Derivation of the real-valued P_N equations from the RTE (DESIGN.md §2).
//!
//! Contract used by the discretizer: [`PnSystem::equations`] holds one [`PnEquation`] per
//! (l, m) with l ≤ N, ordered by the moment index l(l+1)+m, each written as `lhs = rhs` with
//!
//! * `lhs` a sum of terms `c · ∂_d L_{l'}^{m'}` (as `Mul[Num(c), Deriv(d, Coeff L)]`),
//!   `σ_t · L_l^m` (`Mul[Field(SigmaT), Coeff L]`) and
//!   `−σ_s · λ_l p_l · L_l^m` (`Mul[Num(-1), Field(SigmaS), Field(PhaseMoment(Int l)), Coeff L]`);
//! * `rhs` the source coefficient `Q_l^m` (`Coeff Q`).

use cas::Expr;

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
}

/// The expanded real P_N system of one order N.
#[derive(Clone, Debug)]
pub struct PnSystem {
    /// The order N.
    pub order: usize,
    /// Equations ordered by l(l+1)+m.
    pub equations: Vec<PnEquation>,
}
