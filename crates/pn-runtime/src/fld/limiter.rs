//! Flux limiters F(R) for flux-limited diffusion.
//!
//! The FLD diffusion coefficient is `D_F = F(R) / σ_t` with the Knudsen number
//! `R = |∇φ| / (σ_t φ)` (Koerner et al. 2014, "Flux-limited diffusion for multiple scattering
//! in participating media"). Every limiter here satisfies the two limits that make FLD a
//! diffusion theory with a bounded flux:
//!
//! * `F(R) → 1/3` as `R → 0` (optically thick: classical diffusion, `D = 1/(3σ_t)`), and
//! * `R·F(R) → 1` as `R → ∞` (free streaming: `|E| = D|∇φ| = R F(R) φ → φ`),
//!
//! and `R·F(R) ≤ 1` for all `R ≥ 0`, i.e. `|E| ≤ φ`. CDA is the constant limiter `F = 1/3`,
//! which meets the first limit only.

use std::fmt;
use std::str::FromStr;

/// Below this Knudsen number the Levermore–Pomraning limiter is evaluated from its Taylor
/// series. The first omitted term is `2R⁸/93555 ≈ 8e-16` at the threshold (relative to 1/3),
/// while the closed form `coth R − 1/R` loses about `log10(3/R²)` digits to cancellation.
const LP_SERIES_THRESHOLD: f64 = 0.05;

/// A flux limiter `F(R)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Limiter {
    /// Classical diffusion: `F = 1/3` for every `R` (no flux limiting).
    Cda,
    /// Sum limiter `F = 1/(3 + R)`.
    Sum,
    /// Max limiter `F = 1/max(3, R)`.
    Max,
    /// Kershaw limiter `F = 2/(3 + √(9 + 4R²))`.
    Kershaw,
    /// Larsen limiter of order `n > 0`: `F = (3ⁿ + Rⁿ)^(−1/n)` (`n = 2` is "larsen2").
    Larsen(f64),
    /// Levermore–Pomraning limiter `F = (coth R − 1/R)/R`.
    LevermorePomraning,
}

impl Limiter {
    /// The names accepted by [`FromStr`] (`larsen<n>` accepts any positive number `n`).
    pub const NAMES: &'static str = "lp, sum, max, kershaw, larsen2 (or larsen<n>), cda";

    /// Evaluates `F(R)` for a Knudsen number `R ≥ 0`.
    ///
    /// Every branch is finite and positive for finite `R ≥ 0` and tends to 0 for `R → ∞`.
    /// Negative or NaN input (not a Knudsen number) is treated as `R = 0`, so that a solver
    /// never produces NaN from it.
    pub fn eval(&self, r: f64) -> f64 {
        let r = if r >= 0.0 { r } else { 0.0 };
        match *self {
            Limiter::Cda => 1.0 / 3.0,
            Limiter::Sum => 1.0 / (3.0 + r),
            Limiter::Max => 1.0 / r.max(3.0),
            // 2/(3 + √(9 + 4R²)); hypot avoids overflow of R² for huge R.
            Limiter::Kershaw => 2.0 / (3.0 + 3.0_f64.hypot(2.0 * r)),
            Limiter::Larsen(n) => larsen(r, n),
            Limiter::LevermorePomraning => levermore_pomraning(r),
        }
    }

    /// Whether `F` depends on `R` at all (false only for CDA).
    pub fn is_nonlinear(&self) -> bool {
        !matches!(self, Limiter::Cda)
    }

    /// Checks parameters of the limiter (the Larsen order must be finite and positive).
    pub fn validate(&self) -> anyhow::Result<()> {
        if let Limiter::Larsen(n) = *self {
            if !(n.is_finite() && n > 0.0) {
                anyhow::bail!("Larsen limiter order must be a finite positive number, got {n}");
            }
        }
        Ok(())
    }
}

/// `(3ⁿ + Rⁿ)^(−1/n)` evaluated as `m⁻¹ (1 + (s/m)ⁿ)^(−1/n)` with `m = max(3, R)`,
/// `s = min(3, R)`, which cannot overflow for large `R` or large `n`.
fn larsen(r: f64, n: f64) -> f64 {
    let (m, s) = if r > 3.0 { (r, 3.0) } else { (3.0, r) };
    (1.0 + (s / m).powf(n)).powf(-1.0 / n) / m
}

/// Levermore–Pomraning `(coth R − 1/R)/R`.
///
/// For small `R` the series `coth R − 1/R = R/3 − R³/45 + 2R⁵/945 − R⁷/4725 + …` gives
/// `F = 1/3 − R²/45 + 2R⁴/945 − R⁶/4725`. Otherwise `coth R = 1 + 2/expm1(2R)`, which is
/// exact-to-rounding for large `R` (the correction underflows to 0, no overflow).
fn levermore_pomraning(r: f64) -> f64 {
    if r < LP_SERIES_THRESHOLD {
        let r2 = r * r;
        1.0 / 3.0 + r2 * (-1.0 / 45.0 + r2 * (2.0 / 945.0 - r2 / 4725.0))
    } else {
        let coth = 1.0 + 2.0 / (2.0 * r).exp_m1();
        (coth - 1.0 / r) / r
    }
}

impl FromStr for Limiter {
    type Err = anyhow::Error;

    /// Parses `lp | levermore-pomraning | sum | max | kershaw | larsen2 | larsen<n> | cda`
    /// (case-insensitive).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let name = s.trim().to_ascii_lowercase();
        let limiter = match name.as_str() {
            "lp" | "levermore-pomraning" | "levermore_pomraning" => Limiter::LevermorePomraning,
            "sum" => Limiter::Sum,
            "max" => Limiter::Max,
            "kershaw" => Limiter::Kershaw,
            "cda" => Limiter::Cda,
            other => match other.strip_prefix("larsen") {
                Some(order) => {
                    let n: f64 = order.parse().map_err(|_| {
                        anyhow::anyhow!(
                            "invalid Larsen limiter order {order:?} in {s:?}: expected e.g. larsen2"
                        )
                    })?;
                    let lim = Limiter::Larsen(n);
                    lim.validate()?;
                    lim
                }
                None => anyhow::bail!(
                    "unknown flux limiter {s:?}; expected one of: {}",
                    Limiter::NAMES
                ),
            },
        };
        Ok(limiter)
    }
}

impl fmt::Display for Limiter {
    /// The name [`FromStr`] parses (`larsen<n>` for Larsen); honours width and alignment.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Limiter::Cda => f.pad("cda"),
            Limiter::Sum => f.pad("sum"),
            Limiter::Max => f.pad("max"),
            Limiter::Kershaw => f.pad("kershaw"),
            Limiter::Larsen(n) => f.pad(&format!("larsen{n}")),
            Limiter::LevermorePomraning => f.pad("lp"),
        }
    }
}
