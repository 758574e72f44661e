//! The Krylov methods for square systems ([`super::cg`], [`super::bicgstab`],
//! [`super::gmres`]) by name, for the solvers that choose one at run time (the parity
//! solvers by the measured symmetry of the reduced operator, multigrid-CG on a scalar
//! system), and the symmetry threshold they choose by.

use crate::control::{Control, Outcome};
use crate::operator::{LinearOperator, Preconditioner};

/// An operator counts as symmetric when its random-probe asymmetry
/// `|xᵀAy − yᵀAx| / (‖x‖‖Ay‖ + ‖y‖‖Ax‖)` is below this. Rounding in the probe's dot
/// products is ~√n·ε ≈ 1e-14 for n ≤ 1e6; a genuine boundary asymmetry of the Neumann
/// closure is orders of magnitude larger (≥ 1e-6 of the scale on the checkerboard).
pub const SYMMETRY_TOL: f64 = 1e-12;

/// A Krylov method for square systems.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum KrylovMethod {
    /// Preconditioned conjugate gradients ([`super::cg`]).
    Cg,
    /// Right-preconditioned BiCGSTAB ([`super::bicgstab`]).
    BiCgStab,
    /// Right-preconditioned restarted GMRES ([`super::gmres`]).
    Gmres,
}

impl KrylovMethod {
    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            KrylovMethod::Cg => "cg",
            KrylovMethod::BiCgStab => "bicgstab",
            KrylovMethod::Gmres => "gmres",
        }
    }

    /// The method named `cg`, `bicgstab` or `gmres`; `None` for any other name.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "cg" => Some(KrylovMethod::Cg),
            "bicgstab" => Some(KrylovMethod::BiCgStab),
            "gmres" => Some(KrylovMethod::Gmres),
            _ => None,
        }
    }

    /// Runs the method on `a x = f` from `x` with the preconditioner `m` (default
    /// parameters).
    pub fn run(
        self,
        a: &dyn LinearOperator,
        m: &dyn Preconditioner,
        f: &[f64],
        x: &mut [f64],
        ctl: &mut Control,
    ) -> Outcome {
        match self {
            KrylovMethod::Cg => crate::cg::cg(a, m, f, x, ctl),
            KrylovMethod::BiCgStab => crate::bicgstab::bicgstab(a, m, f, x, ctl),
            KrylovMethod::Gmres => crate::gmres::gmres(a, m, f, x, ctl),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for m in [
            KrylovMethod::Cg,
            KrylovMethod::BiCgStab,
            KrylovMethod::Gmres,
        ] {
            assert_eq!(KrylovMethod::from_name(m.name()), Some(m));
        }
        assert_eq!(KrylovMethod::from_name("minres"), None);
    }
}
