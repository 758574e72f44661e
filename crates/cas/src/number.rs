//! Exact numbers: `r · √s` with `r` rational and `s` a square-free positive integer
//! (canonical form).
//!
//! Arithmetic (multiplication, division, integer powers, square roots of rationals, and
//! addition of like surds) lives here; sums of unlike surds are represented in the
//! expression tree as `Expr::Add`.
//!
//! Intermediate products are computed in 128-bit integers and reduced before they are
//! stored, so coefficients of P_N equations up to very high orders stay exact; a result
//! that does not fit 64 bits after reduction panics with a clear message (the derivation
//! limits the order so that this cannot be reached from user input).

use num_integer::Integer;
use num_rational::{Ratio, Rational64};
use num_traits::{One, Signed, ToPrimitive, Zero};
use std::fmt;

/// An exact number `coeff · √radicand`, with `radicand` a square-free positive integer
/// (stored as a rational with denominator 1). Canonical: `radicand == 1` for plain
/// rationals, and `coeff == 0 ⇒ radicand == 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Surd {
    /// Rational factor in front of the root.
    pub coeff: Rational64,
    /// Square-free radicand.
    pub radicand: Rational64,
}

type R128 = Ratio<i128>;

#[expect(
    clippy::panic,
    reason = "Surd is exact i64 arithmetic by design: the P_N derivation up to MAX_ORDER stays far inside it, and a silently rounded coefficient would be worse than stopping"
)]
fn to_r64(r: R128) -> Rational64 {
    let n = r.numer().to_i64();
    let d = r.denom().to_i64();
    match (n, d) {
        (Some(n), Some(d)) => Rational64::new_raw(n, d),
        _ => panic!("cas::Surd: exact coefficient overflows 64 bits ({r})"),
    }
}

fn to_r128(r: Rational64) -> R128 {
    R128::new_raw(*r.numer() as i128, *r.denom() as i128)
}

/// Splits `n > 0` into `(k, s)` with `n = k² s` and `s` square-free.
fn square_free_split(mut n: i128) -> (i128, i128) {
    debug_assert!(n > 0);
    let mut k: i128 = 1;
    let mut s: i128 = 1;
    let mut p: i128 = 2;
    while p * p <= n {
        let mut e = 0;
        while n % p == 0 {
            n /= p;
            e += 1;
        }
        for _ in 0..e / 2 {
            k *= p;
        }
        if e % 2 == 1 {
            s *= p;
        }
        p += if p == 2 { 1 } else { 2 };
    }
    (k, s * n)
}

impl Surd {
    /// Zero.
    pub const ZERO: Surd = Surd {
        coeff: Ratio::new_raw(0, 1),
        radicand: Ratio::new_raw(1, 1),
    };
    /// One.
    pub const ONE: Surd = Surd {
        coeff: Ratio::new_raw(1, 1),
        radicand: Ratio::new_raw(1, 1),
    };

    /// The rational `p/q` (panics if `q == 0`).
    pub fn rational(p: i64, q: i64) -> Surd {
        Surd {
            coeff: Rational64::new(p, q),
            radicand: Rational64::one(),
        }
    }

    /// The integer `n`.
    pub fn from_int(n: i64) -> Surd {
        Surd::rational(n, 1)
    }

    /// A rational given as [`Rational64`].
    pub fn from_ratio(r: Rational64) -> Surd {
        Surd {
            coeff: r,
            radicand: Rational64::one(),
        }
    }

    /// Canonical `c · √r` from a rational `c` and a non-negative rational `r`
    /// (returns `None` for a negative radicand).
    pub fn new(coeff: Rational64, radicand: Rational64) -> Option<Surd> {
        Self::new128(to_r128(coeff), to_r128(radicand))
    }

    #[expect(
        clippy::expect_used,
        reason = "Surd is exact arithmetic in a fixed width by design: the radicands of the P_N derivation up to MAX_ORDER are ratios of small integers, far from overflowing p·q in i128, and stopping beats a silently wrong coefficient"
    )]
    fn new128(coeff: R128, radicand: R128) -> Option<Surd> {
        if radicand.is_negative() {
            return None;
        }
        if coeff.is_zero() || radicand.is_zero() {
            return Some(Surd::ZERO);
        }
        // √(p/q) = √(p·q)/q, then pull square factors out of p·q.
        let (p, q) = (*radicand.numer(), *radicand.denom());
        let (k, s) = square_free_split(p.checked_mul(q).expect("cas::Surd: radicand overflow"));
        let c = coeff * R128::new(k, q);
        Some(Surd {
            coeff: to_r64(c),
            radicand: to_r64(R128::from_integer(s)),
        })
    }

    /// `√r` of a non-negative rational (`None` if negative).
    pub fn sqrt_of(r: Rational64) -> Option<Surd> {
        Surd::new(Rational64::one(), r)
    }

    /// `√(p/q)` for integers (`None` if negative or `q == 0`).
    pub fn sqrt_ratio(p: i64, q: i64) -> Option<Surd> {
        if q == 0 {
            return None;
        }
        Surd::sqrt_of(Rational64::new(p, q))
    }

    /// `√self`, defined when `self` is a non-negative rational.
    pub fn sqrt(&self) -> Option<Surd> {
        if self.is_rational() {
            Surd::sqrt_of(self.coeff)
        } else {
            None
        }
    }

    /// True if the radicand is 1.
    pub fn is_rational(&self) -> bool {
        self.radicand.is_one()
    }
    /// True for 0.
    pub fn is_zero(&self) -> bool {
        self.coeff.is_zero()
    }
    /// True for 1.
    pub fn is_one(&self) -> bool {
        self.coeff.is_one() && self.radicand.is_one()
    }
    /// True for a negative number.
    pub fn is_negative(&self) -> bool {
        self.coeff.is_negative()
    }
    /// The integer value, if this is an integer.
    pub fn as_integer(&self) -> Option<i64> {
        (self.is_rational() && self.coeff.is_integer()).then(|| *self.coeff.numer())
    }

    /// Product.
    pub fn mul(&self, o: &Surd) -> Surd {
        // (c1√r1)(c2√r2) = c1 c2 g √((r1/g)(r2/g)), g = gcd(r1, r2); both square-free.
        let r1 = *self.radicand.numer() as i128;
        let r2 = *o.radicand.numer() as i128;
        let g = r1.gcd(&r2);
        let c = to_r128(self.coeff) * to_r128(o.coeff) * R128::from_integer(g);
        if c.is_zero() {
            return Surd::ZERO;
        }
        Surd {
            coeff: to_r64(c),
            radicand: to_r64(R128::from_integer((r1 / g) * (r2 / g))),
        }
    }

    /// Reciprocal (`None` for 0).
    pub fn recip(&self) -> Option<Surd> {
        if self.is_zero() {
            return None;
        }
        // 1/(c√r) = √r / (c r)
        let r = to_r128(self.radicand);
        Some(Surd {
            coeff: to_r64(R128::one() / (to_r128(self.coeff) * r)),
            radicand: self.radicand,
        })
    }

    /// Negation.
    pub fn neg(&self) -> Surd {
        Surd {
            coeff: -self.coeff,
            radicand: self.radicand,
        }
    }

    /// Integer power (`None` for 0 to a negative power).
    pub fn powi(&self, e: i64) -> Option<Surd> {
        let base = if e < 0 { self.recip()? } else { *self };
        let mut acc = Surd::ONE;
        for _ in 0..e.unsigned_abs() {
            acc = acc.mul(&base);
        }
        Some(acc)
    }

    /// Sum, if both have the same radicand (or one is zero).
    pub fn add_like(&self, o: &Surd) -> Option<Surd> {
        if self.is_zero() {
            return Some(*o);
        }
        if o.is_zero() {
            return Some(*self);
        }
        if self.radicand != o.radicand {
            return None;
        }
        let c = to_r128(self.coeff) + to_r128(o.coeff);
        if c.is_zero() {
            return Some(Surd::ZERO);
        }
        Some(Surd {
            coeff: to_r64(c),
            radicand: self.radicand,
        })
    }

    /// Floating-point value.
    pub fn to_f64(&self) -> f64 {
        let c = *self.coeff.numer() as f64 / *self.coeff.denom() as f64;
        let r = *self.radicand.numer() as f64 / *self.radicand.denom() as f64;
        c * r.sqrt()
    }
}

impl Surd {
    /// ASCII text form for tools: `-3/2`, `sqrt(2)`, `-1/3*sqrt(6)`.
    pub fn to_text(&self) -> String {
        if self.is_rational() {
            return self.coeff.to_string();
        }
        let r = self.radicand.numer();
        if self.coeff.is_one() {
            format!("sqrt({r})")
        } else if (-self.coeff).is_one() {
            format!("-sqrt({r})")
        } else {
            format!("{}*sqrt({r})", self.coeff)
        }
    }
}

impl fmt::Display for Surd {
    /// Plain-text form such as `-3/2`, `√2`, `-1/3·√6`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_rational() {
            return write!(f, "{}", self.coeff);
        }
        let r = self.radicand.numer();
        if self.coeff.is_one() {
            write!(f, "√{r}")
        } else if (-self.coeff).is_one() {
            write!(f, "-√{r}")
        } else {
            write!(f, "{}·√{r}", self.coeff)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(p: i64, d: i64) -> Rational64 {
        Rational64::new(p, d)
    }

    #[test]
    fn sqrt_half_times_sqrt_two_is_one() {
        let a = Surd::sqrt_of(q(1, 2)).unwrap();
        let b = Surd::sqrt_of(q(2, 1)).unwrap();
        assert_eq!(a.mul(&b), Surd::ONE);
        // √(1/2) is canonically (1/2)√2.
        assert_eq!(a.coeff, q(1, 2));
        assert_eq!(a.radicand, q(2, 1));
    }

    #[test]
    fn sqrt_eight_is_two_sqrt_two() {
        let s = Surd::sqrt_of(q(8, 1)).unwrap();
        assert_eq!(s.coeff, q(2, 1));
        assert_eq!(s.radicand, q(2, 1));
        assert_eq!(s.to_string(), "2·√2");
        assert_eq!(s.to_text(), "2*sqrt(2)");
        assert_eq!(Surd::sqrt_ratio(1, 3).unwrap().to_text(), "1/3*sqrt(3)");
    }

    #[test]
    fn canonical_forms_and_arithmetic() {
        assert_eq!(Surd::sqrt_of(q(0, 1)).unwrap(), Surd::ZERO);
        assert_eq!(Surd::sqrt_of(q(9, 4)).unwrap(), Surd::rational(3, 2));
        assert!(Surd::sqrt_of(q(-1, 1)).is_none());
        let s6 = Surd::sqrt_of(q(6, 1)).unwrap();
        let s10 = Surd::sqrt_of(q(10, 1)).unwrap();
        // √6·√10 = 2√15
        let p = s6.mul(&s10);
        assert_eq!((p.coeff, p.radicand), (q(2, 1), q(15, 1)));
        // 1/√3 = √3/3
        let r = Surd::sqrt_of(q(3, 1)).unwrap().recip().unwrap();
        assert_eq!((r.coeff, r.radicand), (q(1, 3), q(3, 1)));
        assert!((r.to_f64() - 1.0 / 3f64.sqrt()).abs() < 1e-15); // one ulp
                                                                 // like terms add, unlike do not
        assert_eq!(s6.add_like(&s6.neg()), Some(Surd::ZERO));
        assert_eq!(s6.add_like(&s10), None);
        assert_eq!(s6.powi(2), Some(Surd::from_int(6)));
        assert_eq!(s6.powi(-2), Some(Surd::rational(1, 6)));
    }

    #[test]
    fn large_radicands_stay_exact() {
        // A coefficient of order 60: √((61·62)/(123·121)) squared back is rational.
        let s = Surd::sqrt_of(q(61 * 62, 123 * 121)).unwrap();
        assert_eq!(s.mul(&s), Surd::rational(61 * 62, 123 * 121));
    }
}
