//! Rust expression printer: exact numbers become `f64` arithmetic (`2.0_f64.sqrt()`),
//! fields and coefficients become identifiers or calls the generated code provides:
//! `sigma_t`, `sigma_s`, `sigma_a`, `phase_moment(l)`, `diffusion`, `l_coeff(l, m)`,
//! `q_coeff(l, m)`, `d_x(…)`.

use crate::expr::{Axis, Expr, FieldName};
use crate::number::Surd;

/// Rust source for an `f64` expression.
#[expect(
    clippy::expect_used,
    reason = "the match guard checked as_integer().is_some() on the same value"
)]
pub fn rust(e: &Expr) -> String {
    match e {
        Expr::Num(s) => surd(s),
        Expr::Int(n) => format!("{n}"),
        Expr::Sym(s) | Expr::Index(s) => sanitize(s),
        Expr::Add(ts) => format!("({})", ts.iter().map(rust).collect::<Vec<_>>().join(" + ")),
        Expr::Mul(fs) => format!("({})", fs.iter().map(rust).collect::<Vec<_>>().join(" * ")),
        Expr::Pow(b, x) => match x.as_number() {
            Some(s) if s == Surd::rational(1, 2) => format!("({}).sqrt()", rust(b)),
            Some(s) if s.as_integer().is_some() => {
                format!("({}).powi({})", rust(b), s.as_integer().expect("integer"))
            }
            _ => format!("({}).powf({})", rust(b), rust(x)),
        },
        Expr::Delta(a, b) => format!("(if {} == {} {{ 1.0 }} else {{ 0.0 }})", rust(a), rust(b)),
        Expr::Field(f) => match f {
            FieldName::SigmaT => "sigma_t".into(),
            FieldName::SigmaS => "sigma_s".into(),
            FieldName::SigmaA => "sigma_a".into(),
            FieldName::PhaseMoment(l) => format!("phase_moment({})", rust(l)),
            FieldName::Diffusion => "diffusion".into(),
            FieldName::Named(n) => sanitize(n),
        },
        Expr::Coeff { name, l, m, .. } => {
            format!(
                "{}_coeff({}, {})",
                sanitize(&name.to_lowercase()),
                rust(l),
                rust(m)
            )
        }
        Expr::Deriv(a, body) => {
            let ax = match a {
                Axis::X => "x",
                Axis::Y => "y",
                Axis::Z => "z",
            };
            format!("d_{ax}({})", rust(body))
        }
        Expr::Func(n, args) => format!(
            "{}({})",
            sanitize(n),
            args.iter().map(rust).collect::<Vec<_>>().join(", ")
        ),
        other => format!("/* not representable in Rust: {other:?} */ f64::NAN"),
    }
}

fn sanitize(s: &str) -> String {
    let s: String = s
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    s.trim_matches('_').to_string()
}

/// `c·√r` as `f64` arithmetic with exact integer literals.
pub fn surd(s: &Surd) -> String {
    let (p, q) = (*s.coeff.numer(), *s.coeff.denom());
    let mut out = format!("{p}.0_f64");
    if q != 1 {
        out = format!("({out} / {q}.0)");
    }
    if !s.is_rational() {
        out = format!("({out} * {}.0_f64.sqrt())", s.radicand.numer());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prints_compilable_arithmetic() {
        let s = Surd::sqrt_of(num_rational::Rational64::new(1, 3)).unwrap();
        assert_eq!(surd(&s), "((1.0_f64 / 3.0) * 3.0_f64.sqrt())");
        // The printed value evaluates to the number.
        let v: f64 = (1.0_f64 / 3.0) * 3.0_f64.sqrt();
        assert!((v - s.to_f64()).abs() < 1e-16);
        let e = Expr::Mul(vec![Expr::field(FieldName::SigmaT), Expr::moment(1, 0)]);
        assert_eq!(rust(&e), "(sigma_t * l_coeff(1, 0))");
    }
}
