//! LaTeX printer with operator precedence: sums are parenthesized inside products,
//! powers and derivatives; negative terms of a sum print as subtraction; reciprocal
//! factors print as fractions; `x^{1/2}` prints as `\sqrt{x}`.

use crate::expr::{Axis, DirVar, Expr, FieldName, ShKind};
use crate::number::Surd;

/// Precedence levels (higher binds tighter).
#[derive(Clone, Copy, PartialEq, PartialOrd)]
enum Prec {
    Sum = 1,
    Product = 2,
    Power = 3,
    Atom = 4,
}

/// LaTeX for an expression.
pub fn latex(e: &Expr) -> String {
    print(e).0
}

fn axis(a: Axis) -> &'static str {
    match a {
        Axis::X => "x",
        Axis::Y => "y",
        Axis::Z => "z",
    }
}

fn dir(d: DirVar) -> &'static str {
    match d {
        DirVar::Omega => "\\omega",
        DirVar::OmegaPrime => "\\omega'",
    }
}

/// LaTeX for a surd (with its sign).
pub fn surd(s: &Surd) -> String {
    let (p, q) = (*s.coeff.numer(), *s.coeff.denom());
    let sign = if p < 0 { "-" } else { "" };
    let p = p.unsigned_abs();
    let root = if s.is_rational() {
        String::new()
    } else {
        format!("\\sqrt{{{}}}", s.radicand.numer())
    };
    let top = match (p, root.is_empty()) {
        (_, true) => p.to_string(),
        (1, false) => root.clone(),
        (_, false) => format!("{p}{root}"),
    };
    if q == 1 {
        format!("{sign}{top}")
    } else {
        format!("{sign}\\frac{{{top}}}{{{q}}}")
    }
}

fn wrap(e: &Expr, min: Prec) -> String {
    let (s, p) = print(e);
    if p < min {
        format!("\\left({s}\\right)")
    } else {
        s
    }
}

/// Index expressions print without `\left(`: `l+1`, `-m`, `2l-1`.
fn idx(e: &Expr) -> String {
    latex(e).replace(" + ", "+").replace(" - ", "-")
}

fn print(e: &Expr) -> (String, Prec) {
    use Prec::*;
    match e {
        Expr::Num(s) => {
            let p = if s.is_negative() || !s.coeff.is_integer() {
                Product
            } else {
                Atom
            };
            (surd(s), if s.is_negative() { Sum } else { p })
        }
        Expr::Int(n) => (n.to_string(), if *n < 0 { Sum } else { Atom }),
        Expr::Sym(s) | Expr::Index(s) => (s.clone(), Atom),
        Expr::I => ("i".into(), Atom),
        Expr::Add(ts) => {
            let mut out = String::new();
            for (k, t) in ts.iter().enumerate() {
                let (neg, body) = negated(t);
                let s = match &body {
                    Some(b) => wrap(b, Product),
                    None => wrap(t, Product),
                };
                if k == 0 {
                    out.push_str(if neg { "-" } else { "" });
                } else {
                    out.push_str(if neg { " - " } else { " + " });
                }
                out.push_str(&s);
            }
            (out, Sum)
        }
        Expr::Mul(fs) => print_product(fs),
        Expr::Pow(b, x) => {
            if let Some(s) = x.as_number() {
                if s == Surd::rational(1, 2) {
                    return (format!("\\sqrt{{{}}}", latex(b)), Atom);
                }
                if s == Surd::rational(-1, 1) {
                    return (format!("\\frac{{1}}{{{}}}", latex(b)), Atom);
                }
                if s == Surd::rational(-1, 2) {
                    return (format!("\\frac{{1}}{{\\sqrt{{{}}}}}", latex(b)), Atom);
                }
            }
            (format!("{}^{{{}}}", wrap(b, Atom), latex(x)), Power)
        }
        Expr::Conj(a) => (format!("\\overline{{{}}}", latex(a)), Atom),
        Expr::Delta(a, b) => (format!("\\delta_{{{},{}}}", idx(a), idx(b)), Atom),
        Expr::Field(f) => (field(f), Atom),
        Expr::Func(name, args) => (func(name, args), Atom),
        Expr::DirComp(d, a) => (format!("{}_{}", dir(*d), axis(*a)), Atom),
        Expr::Sh {
            kind,
            l,
            m,
            dir: d,
            conj,
        } => {
            let core = match kind {
                ShKind::Real => format!("Y_{{{},{}}}", idx(l), idx(m)),
                ShKind::Complex => format!("Y_{{{}}}^{{{}}}", idx(l), idx(m)),
            };
            let core = if *conj {
                format!("\\overline{{{core}}}")
            } else {
                core
            };
            (format!("{core}({})", dir(*d)), Atom)
        }
        Expr::Coeff { name, kind, l, m } => {
            let n = match kind {
                ShKind::Real => name.clone(),
                ShKind::Complex => format!("\\tilde{{{name}}}"),
            };
            (format!("{n}_{{{}}}^{{{}}}", idx(l), idx(m)), Atom)
        }
        Expr::Sum {
            index,
            lo,
            hi,
            body,
        } => {
            let hi = hi.as_ref().map_or("\\infty".to_string(), |h| latex(h));
            (
                format!(
                    "\\sum_{{{index}={}}}^{{{hi}}} {}",
                    latex(lo),
                    wrap(body, Product)
                ),
                Product,
            )
        }
        Expr::Integral { var, body } => (
            format!(
                "\\int_{{S^2}} {} \\,\\mathrm{{d}}{}",
                wrap(body, Product),
                dir(*var)
            ),
            Product,
        ),
        Expr::Deriv(a, body) => (
            format!("\\partial_{} {}", axis(*a), wrap(body, Atom)),
            Power,
        ),
    }
}

/// If `t` prints with a leading minus, returns the positive version.
#[expect(clippy::expect_used, reason = "the pop is under rest.len() == 1")]
fn negated(t: &Expr) -> (bool, Option<Expr>) {
    match t {
        Expr::Num(s) if s.is_negative() => (true, Some(Expr::Num(s.neg()))),
        Expr::Int(n) if *n < 0 => (true, Some(Expr::Int(-n))),
        Expr::Mul(fs) => match fs.first().and_then(|f| f.as_number()) {
            Some(s) if s.is_negative() => {
                let mut rest = fs.clone();
                if s == Surd::from_int(-1) {
                    rest.remove(0);
                } else {
                    rest[0] = Expr::Num(s.neg());
                }
                let body = if rest.len() == 1 {
                    rest.pop().expect("one")
                } else {
                    Expr::Mul(rest)
                };
                (true, Some(body))
            }
            _ => (false, None),
        },
        _ => (false, None),
    }
}

fn print_product(fs: &[Expr]) -> (String, Prec) {
    let mut num = Vec::new();
    let mut den = Vec::new();
    let mut sign = "";
    for (k, f) in fs.iter().enumerate() {
        match f {
            Expr::Pow(b, x) if x.as_number() == Some(Surd::from_int(-1)) => {
                den.push(wrap(b, Prec::Product))
            }
            Expr::Num(s) if k == 0 && s.is_negative() && *s == Surd::from_int(-1) => sign = "-",
            Expr::Num(s) if k == 0 && s.is_negative() => {
                sign = "-";
                num.push(surd(&s.neg()));
            }
            Expr::Int(-1) if k == 0 => sign = "-",
            // A leading positive number needs no parentheses: `\frac{1}{2} x`.
            Expr::Num(s) if k == 0 => num.push(surd(s)),
            f => num.push(wrap(f, Prec::Power)),
        }
    }
    let join = |v: &[String]| {
        let mut out = String::new();
        for (k, s) in v.iter().enumerate() {
            if k > 0 {
                let prev_digit = out
                    .chars()
                    .last()
                    .is_some_and(|c| c.is_ascii_digit() || c == '}');
                let next_digit = s
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_ascii_digit() || c == '\\' && s.starts_with("\\frac"));
                out.push_str(if prev_digit && next_digit {
                    " \\cdot "
                } else {
                    " "
                });
            }
            out.push_str(s);
        }
        out
    };
    let body = if den.is_empty() {
        join(&num)
    } else {
        let top = if num.is_empty() {
            "1".to_string()
        } else {
            join(&num)
        };
        format!("\\frac{{{top}}}{{{}}}", join(&den))
    };
    (
        format!("{sign}{body}"),
        if sign.is_empty() {
            Prec::Product
        } else {
            Prec::Sum
        },
    )
}

fn field(f: &FieldName) -> String {
    match f {
        FieldName::SigmaT => "\\sigma_t".into(),
        FieldName::SigmaS => "\\sigma_s".into(),
        FieldName::SigmaA => "\\sigma_a".into(),
        FieldName::PhaseMoment(l) => format!("\\lambda_{{{0}}} p_{{{0}}}", idx(l)),
        FieldName::Diffusion => "D".into(),
        FieldName::Named(n) => n.clone(),
    }
}

fn func(name: &str, args: &[Expr]) -> String {
    match (name, args) {
        ("p", [a, b]) => format!("p({}\\cdot {})", latex(a), latex(b)),
        (n, [l, m]) if n.len() == 1 && "abcdef".contains(n) => {
            format!("{n}_{{{},{}}}", idx(l), idx(m))
        }
        _ => format!(
            "{name}({})",
            args.iter().map(latex).collect::<Vec<_>>().join(", ")
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_precedence() {
        let s2 = Expr::Num(Surd::sqrt_of(num_rational::Rational64::new(1, 2)).unwrap());
        assert_eq!(latex(&s2), "\\frac{\\sqrt{2}}{2}");
        let (a, b, c) = (Expr::sym("a"), Expr::sym("b"), Expr::sym("c"));
        // a (b + c)
        let e = Expr::Mul(vec![a.clone(), Expr::Add(vec![b.clone(), c.clone()])]);
        assert_eq!(latex(&e), "a \\left(b + c\\right)");
        // a − 2b
        let e = Expr::Add(vec![a.clone(), Expr::Mul(vec![Expr::int(-2), b.clone()])]);
        assert_eq!(latex(&e), "a - 2 b");
        // (a + b)^{2}
        let e = Expr::Add(vec![a.clone(), b.clone()]).pow(Expr::int(2));
        assert_eq!(latex(&e), "\\left(a + b\\right)^{2}");
        // a/b
        let e = Expr::Mul(vec![a.clone(), b.clone().recip()]);
        assert_eq!(latex(&e), "\\frac{a}{b}");
    }

    #[test]
    fn physics_nodes() {
        let e = Expr::Mul(vec![
            Expr::rational(1, 3).sqrt(),
            Expr::moment(1, -1).deriv(Axis::Y),
        ]);
        assert_eq!(latex(&e), "\\sqrt{\\frac{1}{3}} \\partial_y L_{1}^{-1}");
        let e = Expr::Add(vec![Expr::index("l"), Expr::Int(1)]);
        assert_eq!(
            latex(&Expr::sh(ShKind::Real, e, Expr::index("m"), DirVar::Omega)),
            "Y_{l+1,m}(\\omega)"
        );
    }
}
