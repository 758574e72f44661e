//! Property tests for the cas: random expression trees evaluate to the same
//! number before and after each value-preserving rewrite pass.
//!
//! The cas has no numeric evaluator for whole trees (only `Surd::to_f64` for numbers), so
//! this file has one: complex arithmetic over Num, Int, Sym, I, Add, Mul, Pow, Conj, Delta,
//! Field, DirComp, real-basis Coeff and Sum with concrete bounds. Symbols and fields take
//! positive values (they stand for h, σ_t, … — the cas may rely on that for √ rules);
//! coefficients and direction components take arbitrary real values.
//!
//! Passes checked: fold, expand, split, pull_factors, collect, normalize, collapse_deltas,
//! delta_substitute, merge_sums. (The SH passes need SH evaluation and are checked by
//! quadrature in pn-codegen.)
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use cas::expr::{Axis, DirVar, Expr, FieldName, ShKind};
use cas::passes::{collect, delta, expand, fold, normalize, pull, split};
use proptest::prelude::*;
use std::collections::HashMap;

#[derive(Clone, Copy, Debug, PartialEq)]
struct C(f64, f64);

impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn abs(self) -> f64 {
        self.0.hypot(self.1)
    }
    fn recip(self) -> C {
        let d = self.0 * self.0 + self.1 * self.1;
        C(self.0 / d, -self.1 / d)
    }
    /// Principal power for a real exponent.
    fn powf(self, x: f64) -> C {
        if x.fract() == 0.0 && x.abs() <= 64.0 {
            let mut r = C(1.0, 0.0);
            let b = if x < 0.0 { self.recip() } else { self };
            for _ in 0..x.abs() as i64 {
                r = r.mul(b);
            }
            return r;
        }
        let (m, a) = (self.abs(), self.1.atan2(self.0));
        let m = m.powf(x);
        C(m * (a * x).cos(), m * (a * x).sin())
    }
}

/// Values of the free symbols, indices and fields.
struct Env {
    syms: HashMap<String, f64>,
    indices: HashMap<String, i64>,
}

/// A deterministic pseudo-random value for a coefficient `name_l^m`.
fn coeff_value(name: &str, l: i64, m: i64) -> f64 {
    let mut h: u64 = 1469598103934665603;
    for b in name.bytes().chain(l.to_le_bytes()).chain(m.to_le_bytes()) {
        h = (h ^ b as u64).wrapping_mul(1099511628211);
    }
    (h % 2001) as f64 / 1000.0 - 1.0
}

/// Evaluates `e`; `None` for nodes this evaluator does not cover.
fn eval(e: &Expr, env: &mut Env) -> Option<C> {
    Some(match e {
        Expr::Num(s) => C(s.to_f64(), 0.0),
        Expr::Int(n) => C(*n as f64, 0.0),
        Expr::Sym(s) => C(*env.syms.get(s)?, 0.0),
        Expr::Index(s) => C(*env.indices.get(s)? as f64, 0.0),
        Expr::I => C(0.0, 1.0),
        Expr::Add(ts) => {
            let mut acc = C(0.0, 0.0);
            for t in ts {
                acc = acc.add(eval(t, env)?);
            }
            acc
        }
        Expr::Mul(fs) => {
            let mut acc = C(1.0, 0.0);
            for f in fs {
                acc = acc.mul(eval(f, env)?);
            }
            acc
        }
        Expr::Pow(b, x) => {
            let x = eval(x, env)?;
            if x.1 != 0.0 {
                return None;
            }
            eval(b, env)?.powf(x.0)
        }
        Expr::Conj(a) => {
            let v = eval(a, env)?;
            C(v.0, -v.1)
        }
        Expr::Delta(a, b) => {
            let (a, b) = (eval(a, env)?, eval(b, env)?);
            C(if a == b { 1.0 } else { 0.0 }, 0.0)
        }
        Expr::Field(f) => {
            let key = match f {
                FieldName::SigmaT => "sigma_t",
                FieldName::SigmaS => "sigma_s",
                FieldName::SigmaA => "sigma_a",
                _ => return None,
            };
            C(*env.syms.get(key)?, 0.0)
        }
        Expr::DirComp(_, axis) => C([0.6, -0.48, 0.64][axis.index()], 0.0),
        Expr::Coeff {
            name,
            kind: ShKind::Real,
            l,
            m,
        } => {
            let (l, m) = (eval(l, env)?, eval(m, env)?);
            C(coeff_value(name, l.0 as i64, m.0 as i64), 0.0)
        }
        Expr::Sum {
            index,
            lo,
            hi: Some(hi),
            body,
        } => {
            let (lo, hi) = (eval(lo, env)?.0 as i64, eval(hi, env)?.0 as i64);
            let saved = env.indices.get(index).copied();
            let mut acc = C(0.0, 0.0);
            for k in lo..=hi {
                env.indices.insert(index.clone(), k);
                acc = acc.add(eval(body, env)?);
            }
            match saved {
                Some(v) => env.indices.insert(index.clone(), v),
                None => env.indices.remove(index),
            };
            acc
        }
        _ => return None,
    })
}

/// Magnitude scale of `e`: like [`eval`] but with |·| of every term (the size of the
/// numbers whose rounding the result carries).
fn magnitude(e: &Expr, env: &mut Env) -> f64 {
    match e {
        Expr::Add(ts) => ts.iter().map(|t| magnitude(t, env)).sum(),
        Expr::Mul(fs) => fs.iter().map(|f| magnitude(f, env)).product(),
        Expr::Sum { body, .. } => 10.0 * magnitude(body, env).max(1.0),
        _ => eval(e, env).map(C::abs).unwrap_or(1.0),
    }
}

fn env() -> Env {
    let syms = [
        ("a", 0.7),
        ("b", 1.9),
        ("h", 0.25),
        ("sigma_t", 3.0),
        ("sigma_s", 1.2),
        ("sigma_a", 1.8),
    ];
    Env {
        syms: syms.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        indices: HashMap::new(),
    }
}

/// A leaf: numbers (rational, surd), positive symbols and fields, I, ω components and
/// real coefficients with concrete l, m.
fn leaf() -> impl Strategy<Value = Expr> {
    prop_oneof![
        (-6i64..7, 1i64..5).prop_map(|(p, q)| Expr::rational(p, q)),
        (1i64..8, 1i64..4).prop_map(|(p, q)| Expr::rational(p, q).sqrt()),
        prop_oneof![Just("a"), Just("b"), Just("h")].prop_map(Expr::sym),
        prop_oneof![
            Just(FieldName::SigmaT),
            Just(FieldName::SigmaS),
            Just(FieldName::SigmaA)
        ]
        .prop_map(Expr::field),
        Just(Expr::I),
        prop_oneof![Just(Axis::X), Just(Axis::Y), Just(Axis::Z)]
            .prop_map(|a| Expr::DirComp(DirVar::Omega, a)),
        (0i64..3, -2i64..3).prop_map(|(l, m)| Expr::coeff(
            "L",
            ShKind::Real,
            Expr::Int(l),
            Expr::Int(m)
        )),
        (0i64..3, 0i64..3).prop_map(|(a, b)| Expr::delta(Expr::Int(a), Expr::Int(b))),
    ]
}

/// Random trees of sums, products, integer powers, square roots of positive symbols,
/// conjugates and delta sums.
fn tree() -> impl Strategy<Value = Expr> {
    leaf().prop_recursive(4, 40, 4, |inner| {
        prop_oneof![
            proptest::collection::vec(inner.clone(), 2..4).prop_map(Expr::Add),
            proptest::collection::vec(inner.clone(), 2..4).prop_map(Expr::Mul),
            (inner.clone(), -2i64..4).prop_map(|(b, n)| b.pow(Expr::int(n))),
            prop_oneof![Just("a"), Just("b")].prop_map(|s| Expr::sym(s).sqrt()),
            inner.clone().prop_map(|e| Expr::Conj(Box::new(e))),
            // Σ_{k=lo}^{hi} δ_{k,v} · L_k^0 · body
            (0i64..2, 2i64..4, 0i64..5, inner).prop_map(|(lo, hi, v, body)| {
                Expr::sum(
                    "k",
                    Expr::Int(lo),
                    Some(Expr::Int(hi)),
                    Expr::Mul(vec![
                        Expr::delta(Expr::index("k"), Expr::Int(v)),
                        Expr::coeff("L", ShKind::Real, Expr::index("k"), Expr::Int(0)),
                        body,
                    ]),
                )
            }),
        ]
    })
}

/// A named rewrite pass.
type Pass = (&'static str, fn(&Expr) -> Expr);

/// The passes under test.
fn passes() -> Vec<Pass> {
    vec![
        ("fold", fold::fold),
        ("expand", expand::expand),
        ("split", split::split),
        ("pull_factors", pull::pull_factors),
        ("collect", collect::collect),
        ("normalize", normalize),
        ("collapse_deltas", delta::collapse_deltas),
        ("delta_substitute", delta::delta_substitute),
        ("merge_sums", split::merge_sums),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn passes_preserve_the_value(e in tree()) {
        let mut en = env();
        let before = eval(&e, &mut en);
        prop_assume!(before.is_some());
        let before = before.unwrap();
        let scale = magnitude(&e, &mut en).max(1.0);
        // Skip trees whose value rounding cannot resolve (huge, or a 0⁻¹).
        prop_assume!(before.abs().is_finite() && scale.is_finite() && scale < 1e8);
        for (name, pass) in passes() {
            let after = pass(&e);
            let v = eval(&after, &mut en);
            prop_assert!(v.is_some(), "{} produced a node the evaluator lacks: {:?}", name, after);
            let v = v.unwrap();
            // f64 rounding of a tree of ≤ 40 nodes with magnitudes ≤ scale: ~40·2.2e-16·scale;
            // 1e-10 relative to the scale leaves a wide margin and still catches any
            // wrong sign, factor or dropped term (all O(1) relative to the scale).
            let tol = 1e-10 * scale;
            prop_assert!(
                (v.0 - before.0).abs() <= tol && (v.1 - before.1).abs() <= tol,
                "{}: {:?} -> {:?}\n{:?}\n->\n{:?}", name, before, v, e, after
            );
        }
    }
}

/// The evaluator itself: a few closed forms.
#[test]
fn evaluator_closed_forms() {
    let mut en = env();
    let e = Expr::add(vec![Expr::sym("a"), Expr::rational(1, 2).sqrt()]);
    let v = eval(&e, &mut en).unwrap();
    assert!((v.0 - (0.7 + 0.5f64.sqrt())).abs() < 1e-15 && v.1 == 0.0);
    let i2 = Expr::mul(vec![Expr::I, Expr::I]);
    assert_eq!(eval(&i2, &mut en).unwrap(), C(-1.0, 0.0));
    let s = Expr::sum(
        "k",
        Expr::Int(0),
        Some(Expr::Int(3)),
        Expr::delta(Expr::index("k"), Expr::Int(2)),
    );
    assert_eq!(eval(&s, &mut en).unwrap(), C(1.0, 0.0));
}
