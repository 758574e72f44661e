//! Exact numbers: `r · √s` with `r`, `s` rational and `s` square-free (canonical form).
//!
//! Arithmetic (multiplication, division, square roots, and addition of like surds) lives
//! here; sums of unlike surds are represented in the expression tree as `Expr::Add`.

use num_rational::Rational64;

/// An exact number `coeff · √radicand`, with `radicand` a non-negative square-free
/// rational in lowest terms (canonical: `radicand == 1` for plain rationals, and
/// `coeff == 0 ⇒ radicand == 1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Surd {
    /// Rational factor in front of the root.
    pub coeff: Rational64,
    /// Square-free radicand.
    pub radicand: Rational64,
}

impl Surd {
    /// The rational `p/q` (panics if `q == 0`).
    pub fn rational(p: i64, q: i64) -> Surd {
        Surd {
            coeff: Rational64::new(p, q),
            radicand: Rational64::from_integer(1),
        }
    }

    /// Floating-point value.
    pub fn to_f64(&self) -> f64 {
        let c = *self.coeff.numer() as f64 / *self.coeff.denom() as f64;
        let r = *self.radicand.numer() as f64 / *self.radicand.denom() as f64;
        c * r.sqrt()
    }
}
