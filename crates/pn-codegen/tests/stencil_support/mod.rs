//! Shared helpers of the stencil tests: a P_N fixture from numerical quadrature, field
//! contexts, and a continuous evaluator of expression trees (for manufactured solutions).
#![allow(dead_code)]

use cas::{Axis, Expr, FieldName};
use pn_codegen::derive::{PnEquation, PnSystem};
use pn_stencil::{FieldContext, FieldRef, HalfOffset};

/// `±√(p/q)` as an exact expression, recovering the rational `v²` (denominators of these
/// coefficients are small).
fn surd_expr(v: f64) -> Expr {
    let v2 = v * v;
    for q in 1..200_000i64 {
        let p = (v2 * q as f64).round();
        if (v2 * q as f64 - p).abs() < 1e-9 {
            let root = Expr::Pow(
                Box::new(Expr::rational(p as i64, q)),
                Box::new(Expr::rational(1, 2)),
            );
            return Expr::Mul(vec![Expr::int(if v < 0.0 { -1 } else { 1 }), root]);
        }
    }
    panic!("no small rational for {v}^2");
}

/// The P_N system in the canonical shape of `pn_codegen::derive`, with the transport
/// coefficients from quadrature (a test fixture independent of the CAS derivation).
pub fn quadrature_pn_system(order: usize) -> PnSystem {
    // The quadrature check of docs/design.md §2.3, independent of the CAS derivation.
    let mats = pn_stencil::quadrature::transport_matrices(order);
    let lm: Vec<(i64, i64)> = (0..=order as i64)
        .flat_map(|l| (-l..=l).map(move |m| (l, m)))
        .collect();
    let equations = lm
        .iter()
        .enumerate()
        .map(|(i, &(l, m))| {
            let mut terms = Vec::new();
            for (d, axis) in Axis::ALL.iter().enumerate() {
                for (j, &(l2, m2)) in lm.iter().enumerate() {
                    let v = mats[d][i][j];
                    if v.abs() > 1e-12 {
                        terms.push(Expr::Mul(vec![
                            surd_expr(v),
                            Expr::moment(l2, m2).deriv(*axis),
                        ]));
                    }
                }
            }
            terms.push(Expr::Mul(vec![
                Expr::Field(FieldName::SigmaT),
                Expr::moment(l, m),
            ]));
            terms.push(Expr::Mul(vec![
                Expr::int(-1),
                Expr::Field(FieldName::SigmaS),
                Expr::Field(FieldName::PhaseMoment(Box::new(Expr::Int(l)))),
                Expr::moment(l, m),
            ]));
            PnEquation {
                l,
                m,
                lhs: Expr::Add(terms),
                rhs: Expr::source(l, m),
                // The structured form is not used by the discretizer.
                terms: Vec::new(),
            }
        })
        .collect();
    PnSystem { order, equations }
}

/// The P_N system used by the tests: the CAS derivation.
pub fn pn_system(order: usize) -> PnSystem {
    pn_codegen::discretize::derive_pn(order).expect("P_N derivation")
}

/// splitmix64.
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) from a seed and a string key.
pub fn rand01(seed: u64, key: &str) -> f64 {
    let mut h = seed;
    for b in key.bytes() {
        h = mix(h ^ u64::from(b));
    }
    (mix(h) >> 11) as f64 / (1u64 << 53) as f64
}

/// Field values drawn at random per (field, offset) in [0.5, 1.5), and random 1/h.
pub struct RandomFields {
    pub seed: u64,
}

impl FieldContext for RandomFields {
    fn field(&self, field: &FieldRef, offset: HalfOffset) -> f64 {
        0.5 + rand01(self.seed, &format!("{field:?}{offset:?}"))
    }
    fn inv_h(&self, axis: usize) -> f64 {
        1.0 + 3.0 * rand01(self.seed, &format!("h{axis}"))
    }
}

/// Smooth analytic test problem: fields, an exact solution for every moment, and the
/// continuous operator applied to it.
pub struct Manufactured {
    /// Phase-function asymmetry g(x) enters as λ_l p_l = g^l (Henyey–Greenstein).
    pub seed: u64,
}

impl Manufactured {
    fn wave(&self, key: &str, x: [f64; 3], amp: f64, base: f64) -> f64 {
        let k: Vec<f64> = (0..3)
            .map(|d| 0.5 + 1.5 * rand01(self.seed, &format!("{key}k{d}")))
            .collect();
        let ph = 6.0 * rand01(self.seed, &format!("{key}ph"));
        base + amp * (k[0] * x[0] + k[1] * x[1] + k[2] * x[2] + ph).sin()
    }
    fn g(&self, x: [f64; 3]) -> f64 {
        self.wave("g", x, 0.2, 0.3)
    }
    /// A field at a physical position.
    pub fn field(&self, f: &FieldName, x: [f64; 3]) -> f64 {
        match f {
            FieldName::SigmaT => self.wave("st", x, 0.5, 2.0),
            FieldName::SigmaS => self.wave("ss", x, 0.3, 1.0),
            FieldName::SigmaA => {
                self.field(&FieldName::SigmaT, x) - self.field(&FieldName::SigmaS, x)
            }
            FieldName::Diffusion => self.wave("D", x, 0.2, 0.5),
            FieldName::PhaseMoment(l) => match l.as_ref() {
                Expr::Int(l) => self.g(x).powi(*l as i32),
                other => panic!("phase moment {other:?}"),
            },
            FieldName::Named(n) => panic!("field {n}"),
        }
    }
    /// The exact solution `L_l^m(x)`; z-independent if `two_d`.
    pub fn exact(&self, l: i64, m: i64, x: [f64; 3], two_d: bool) -> f64 {
        let x = if two_d { [x[0], x[1], 0.0] } else { x };
        self.wave(&format!("L{l},{m}"), x, 1.0, 0.5)
    }
    /// The continuous value of `e` at `x` with the exact solution substituted.
    /// Derivatives by 4th-order central differences with step δ = 1e-3 (truncation
    /// ~δ⁴ = 1e-12, round-off ~1e-16/δ per level: far below the residuals measured).
    pub fn eval(&self, e: &Expr, x: [f64; 3], two_d: bool) -> f64 {
        match e {
            Expr::Num(s) => s.to_f64(),
            Expr::Int(n) => *n as f64,
            Expr::Add(ts) => ts.iter().map(|t| self.eval(t, x, two_d)).sum(),
            Expr::Mul(fs) => fs.iter().map(|f| self.eval(f, x, two_d)).product(),
            Expr::Pow(b, p) => self.eval(b, x, two_d).powf(self.eval(p, x, two_d)),
            Expr::Field(f) => self.field(f, x),
            Expr::Coeff { name, l, m, .. } if name == "L" => match (l.as_ref(), m.as_ref()) {
                (Expr::Int(l), Expr::Int(m)) => self.exact(*l, *m, x, two_d),
                _ => panic!("symbolic moment"),
            },
            Expr::Deriv(a, c) => {
                let d = a.index();
                let delta = 1e-3;
                let at = |s: f64| {
                    let mut y = x;
                    y[d] += s * delta;
                    self.eval(c, y, two_d)
                };
                (-at(2.0) + 8.0 * at(1.0) - 8.0 * at(-1.0) + at(-2.0)) / (12.0 * delta)
            }
            other => panic!("cannot evaluate {other:?}"),
        }
    }
}

/// Field context of one row at physical position `x` with spacing `h` (equal on all axes):
/// fields exact at `x + offset·h/2`; sources from the continuous operator.
pub struct RowFields<'a> {
    pub problem: &'a Manufactured,
    pub x: [f64; 3],
    pub h: f64,
    pub two_d: bool,
    /// Left-hand sides of the system by (l, m), to compute Q = lhs(exact).
    pub lhs: &'a dyn Fn(u32, i32) -> Expr,
}

impl RowFields<'_> {
    pub fn pos(&self, o: HalfOffset) -> [f64; 3] {
        [0, 1, 2].map(|d| self.x[d] + 0.5 * self.h * f64::from(o[d]))
    }
}

impl FieldContext for RowFields<'_> {
    fn field(&self, field: &FieldRef, offset: HalfOffset) -> f64 {
        let x = self.pos(offset);
        let name = match field {
            FieldRef::SigmaT => FieldName::SigmaT,
            FieldRef::SigmaS => FieldName::SigmaS,
            FieldRef::SigmaA => FieldName::SigmaA,
            FieldRef::Diffusion => FieldName::Diffusion,
            FieldRef::PhaseMoment(l) => FieldName::PhaseMoment(Box::new(Expr::Int(i64::from(*l)))),
            FieldRef::Source { l, m } => {
                return self.problem.eval(&(self.lhs)(*l, *m), x, self.two_d);
            }
        };
        self.problem.field(&name, x)
    }
    fn inv_h(&self, _axis: usize) -> f64 {
        1.0 / self.h
    }
}
