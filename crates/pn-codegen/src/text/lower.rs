//! Lowering of parsed statements into a [`PdeSystem`] of `cas` expressions: loops expanded,
//! definitions substituted, unknowns labelled, `grad`/`div` written out as partial
//! derivatives.

use std::collections::HashMap;

use cas::{Axis, Expr, FieldName, Surd};
use num_rational::Rational64;

use super::lex::Pos;
use super::parse::{Ast, BinOp, Stmt, Target};
use super::{PdeTextError, TextBoundary, TextPde, TextUnknown};
use crate::discretize::math;
use crate::pde::{PdeEquation, PdeSystem};
use pn_stencil::Dim;

/// Nesting limit for definitions (catches `let a = a`).
const MAX_DEPTH: usize = 64;
/// Largest number of loop iterations or sum terms (catches typos such as `0..1000000`).
const MAX_ITER: i64 = 10_000;

/// A lowered value: a scalar expression or a vector (from `grad`).
#[derive(Clone, Debug)]
enum Val {
    S(Expr),
    V([Expr; 3]),
}

/// What names mean inside one expression: loop variables and definition arguments.
#[derive(Clone, Debug, Default)]
struct Scope {
    vars: HashMap<String, Val>,
    /// Inside a `boundary` statement: `dn(…)` is allowed.
    boundary: bool,
}

/// A target resolved at statement time (loop variables known).
#[derive(Clone, Debug)]
enum ResolvedTarget {
    Name(String),
    Label(i64, i64),
}

struct PendingEquation {
    target: ResolvedTarget,
    lhs: Ast,
    rhs: Ast,
    scope: Scope,
    pos: Pos,
}

struct PendingAdd {
    target: ResolvedTarget,
    term: Ast,
    scope: Scope,
    pos: Pos,
}

struct PendingBoundary {
    kind: String,
    target: ResolvedTarget,
    target_pos: Pos,
    lhs: Ast,
    rhs: Ast,
    scope: Scope,
    pos: Pos,
}

/// Resolves a statement's target to its unknown's label (errors at the given position).
type LabelOf<'a> = dyn Fn(&ResolvedTarget, Pos) -> Result<(i64, i64), PdeTextError> + 'a;

/// The boundary kinds a `boundary` statement can state conditions for.
pub(super) const BOUNDARY_KINDS: [&str; 1] = ["marshak"];

/// A declared unknown before labelling.
struct Decl {
    name: String,
    moment: Option<(i64, i64)>,
    at: Option<[u8; 3]>,
    pos: Pos,
}

#[derive(Default)]
struct Lowerer {
    name: Option<String>,
    params: Vec<(String, Expr)>,
    lets: HashMap<String, (Vec<String>, Ast)>,
    decls: Vec<Decl>,
    /// `include pn(N)`: the derived system and where it was included.
    pn: Option<(crate::derive::PnSystem, Pos)>,
    /// Index into `decls` at which the P_N unknowns are inserted.
    pn_at: usize,
    equations: Vec<PendingEquation>,
    adds: Vec<PendingAdd>,
    boundaries: Vec<PendingBoundary>,
    /// `eliminate` statements: the target and where it was written (target position).
    eliminations: Vec<(ResolvedTarget, Pos)>,
    /// Labels of every unknown, by name (filled after the first pass).
    labels: HashMap<String, (i64, i64)>,
}

/// Names the syntax gives a meaning to.
const RESERVED: [&str; 21] = [
    "sigma_t", "sigma_s", "sigma_a", "phase", "Q", "L", "pi", "dx", "dy", "dz", "grad", "div",
    "lap", "sum", "exp", "ln", "sqrt", "sin", "cos", "abs", "dn",
];

/// Lowers the statements; `overrides` replace `param` values.
pub(super) fn lower(
    stmts: &[Stmt],
    overrides: &[(String, String)],
) -> Result<TextPde, PdeTextError> {
    let mut lw = Lowerer::default();
    let mut overrides_left: Vec<&(String, String)> = overrides.iter().collect();
    for s in stmts {
        lw.execute(s, &Scope::default(), &mut overrides_left)?;
    }
    if let Some((name, _)) = overrides_left.first() {
        return Err(PdeTextError {
            line: 0,
            col: 0,
            message: format!(
                "--pde-param {name}: the PDE declares no parameter '{name}' (it has: {})",
                if lw.params.is_empty() {
                    "none".to_string()
                } else {
                    lw.params
                        .iter()
                        .map(|(n, _)| n.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            ),
        });
    }
    lw.finish()
}

/// An exact rational from a decimal literal such as `0.25` or `1e-3`.
fn parse_decimal(s: &str, pos: Pos) -> Result<Surd, PdeTextError> {
    let bad = || {
        PdeTextError::at(
            pos,
            format!("the number {s} is not a finite decimal that fits an exact 64-bit rational"),
        )
    };
    let (mant, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().map_err(|_| bad())?),
        None => (s, 0),
    };
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let digits = format!("{int}{frac}");
    let digits = digits.trim_start_matches('0');
    let num: i64 = if digits.is_empty() {
        0
    } else {
        digits.parse().map_err(|_| bad())?
    };
    let e = exp - frac.len() as i32;
    let ten = |k: i32| -> Option<i64> { 10i64.checked_pow(k.unsigned_abs()) };
    let r = if e >= 0 {
        Rational64::from_integer(num.checked_mul(ten(e).ok_or_else(bad)?).ok_or_else(bad)?)
    } else {
        Rational64::new(num, ten(e).ok_or_else(bad)?)
    };
    Ok(Surd::from_ratio(r))
}

/// The value of a constant expression (numbers, integers, π and arithmetic on them).
pub(super) fn const_value(e: &Expr) -> Option<f64> {
    Some(match e {
        Expr::Num(s) => s.to_f64(),
        Expr::Int(n) => *n as f64,
        Expr::Sym(s) if s == "pi" => std::f64::consts::PI,
        Expr::Add(ts) => ts.iter().map(const_value).sum::<Option<f64>>()?,
        Expr::Mul(fs) => fs.iter().map(const_value).product::<Option<f64>>()?,
        Expr::Pow(b, x) => const_value(b)?.powf(const_value(x)?),
        Expr::Func(f, args) if args.len() == 1 => math(f, const_value(&args[0])?)?,
        _ => return None,
    })
}

impl Lowerer {
    fn execute(
        &mut self,
        s: &Stmt,
        scope: &Scope,
        overrides: &mut Vec<&(String, String)>,
    ) -> Result<(), PdeTextError> {
        match s {
            Stmt::Pde(name, pos) => {
                if self.name.is_some() {
                    return Err(PdeTextError::at(*pos, "a second 'pde' statement"));
                }
                self.name = Some(name.clone());
            }
            Stmt::Param(name, e, pos) => {
                self.check_new_name(name, *pos)?;
                let value = match overrides.iter().position(|(n, _)| n == name) {
                    Some(i) => {
                        let (_, v) = overrides.remove(i);
                        let v = v.trim();
                        let (neg, digits) = match v.strip_prefix('-') {
                            Some(d) => (true, d),
                            None => (false, v),
                        };
                        let s = parse_decimal(digits, *pos).map_err(|_| {
                            PdeTextError::at(
                                *pos,
                                format!("--pde-param {name}={v}: not a decimal number"),
                            )
                        })?;
                        Expr::Num(if neg { s.neg() } else { s })
                    }
                    None => self.scalar(e, scope, 0)?,
                };
                if const_value(&value).is_none_or(|v| !v.is_finite()) {
                    return Err(PdeTextError::at(
                        e.pos(),
                        format!("parameter {name} must be a finite number"),
                    ));
                }
                self.params.push((name.clone(), value));
            }
            Stmt::Let(name, args, body, pos) => {
                self.check_new_name(name, *pos)?;
                self.lets.insert(name.clone(), (args.clone(), body.clone()));
            }
            Stmt::Unknown {
                name,
                moment,
                at,
                pos,
            } => {
                if let Some(d) = self.decls.iter().find(|d| d.name == *name) {
                    return Err(PdeTextError::at(
                        *pos,
                        format!(
                            "unknown {name} is declared twice (first on line {})",
                            d.pos.line
                        ),
                    ));
                }
                self.check_new_name(name, *pos)?;
                let moment = match moment {
                    Some((l, m)) => Some(self.moment_label(l, m, scope)?),
                    None => None,
                };
                let at = match at {
                    Some(xyz) => {
                        let mut s = [0u8; 3];
                        for (d, e) in xyz.iter().enumerate() {
                            let v = self.int(e, scope)?;
                            if v != 0 && v != 1 {
                                return Err(PdeTextError::at(
                                    e.pos(),
                                    format!("a shift is 0 (cell centre) or 1 (half a cell toward +axis), not {v}"),
                                ));
                            }
                            s[d] = v as u8;
                        }
                        Some(s)
                    }
                    None => None,
                };
                self.decls.push(Decl {
                    name: name.clone(),
                    moment,
                    at,
                    pos: *pos,
                });
            }
            Stmt::Equation(target, lhs, rhs, pos) => {
                let target = self.resolve(target, scope)?;
                self.equations.push(PendingEquation {
                    target,
                    lhs: lhs.clone(),
                    rhs: rhs.clone(),
                    scope: scope.clone(),
                    pos: *pos,
                });
            }
            Stmt::AddTerm(target, term, pos) => {
                let target = self.resolve(target, scope)?;
                self.adds.push(PendingAdd {
                    target,
                    term: term.clone(),
                    scope: scope.clone(),
                    pos: *pos,
                });
            }
            Stmt::Boundary {
                kind: (kind, kind_pos),
                target,
                lhs,
                rhs,
                pos,
            } => {
                if !BOUNDARY_KINDS.contains(&kind.as_str()) {
                    return Err(PdeTextError::at(
                        *kind_pos,
                        format!(
                            "unknown boundary kind '{kind}' (expected {}: the conditions that \
                             `--bc {}` applies)",
                            BOUNDARY_KINDS.join(", "),
                            BOUNDARY_KINDS[0]
                        ),
                    ));
                }
                let target_pos = match target {
                    Target::Name(_, p) | Target::Moment(_, _, p) => *p,
                };
                let target = self.resolve(target, scope)?;
                let mut scope = scope.clone();
                scope.boundary = true;
                self.boundaries.push(PendingBoundary {
                    kind: kind.clone(),
                    target,
                    target_pos,
                    lhs: lhs.clone(),
                    rhs: rhs.clone(),
                    scope,
                    pos: *pos,
                });
            }
            Stmt::Eliminate(target, _) => {
                let pos = match target {
                    Target::Name(_, p) | Target::Moment(_, _, p) => *p,
                };
                let target = self.resolve(target, scope)?;
                self.eliminations.push((target, pos));
            }
            Stmt::IncludePn(n, pos) => {
                if self.pn.is_some() {
                    return Err(PdeTextError::at(*pos, "pn(N) is included twice"));
                }
                let order = self.int(n, scope)?;
                if !(1..=pn_stencil::MAX_ORDER as i64).contains(&order) {
                    return Err(PdeTextError::at(
                        n.pos(),
                        format!(
                            "include pn(N): N = {order} is outside 1..={}",
                            pn_stencil::MAX_ORDER
                        ),
                    ));
                }
                let sys = crate::derive::real_pn_system(order as usize)
                    .map_err(|e| PdeTextError::at(*pos, format!("deriving P_{order}: {e}")))?;
                self.pn = Some((sys, *pos));
                self.pn_at = self.decls.len();
            }
            Stmt::For(ranges, body, _) => self.run_loop(ranges, 0, body, scope, overrides)?,
        }
        Ok(())
    }

    fn run_loop(
        &mut self,
        ranges: &[(String, Ast, Ast)],
        k: usize,
        body: &Stmt,
        scope: &Scope,
        overrides: &mut Vec<&(String, String)>,
    ) -> Result<(), PdeTextError> {
        let Some((var, lo, hi)) = ranges.get(k) else {
            return self.execute(body, scope, overrides);
        };
        let (a, b) = (self.int(lo, scope)?, self.int(hi, scope)?);
        if b - a >= MAX_ITER {
            return Err(PdeTextError::at(
                lo.pos(),
                format!("the range {a}..{b} has more than {MAX_ITER} values"),
            ));
        }
        for v in a..=b {
            let mut inner = scope.clone();
            inner
                .vars
                .insert(var.clone(), Val::S(Expr::Num(Surd::from_int(v))));
            self.run_loop(ranges, k + 1, body, &inner, overrides)?;
        }
        Ok(())
    }

    fn check_new_name(&self, name: &str, pos: Pos) -> Result<(), PdeTextError> {
        if RESERVED.contains(&name) {
            return Err(PdeTextError::at(
                pos,
                format!("'{name}' is a built-in name and cannot be redefined"),
            ));
        }
        if self.params.iter().any(|(n, _)| n == name) || self.lets.contains_key(name) {
            return Err(PdeTextError::at(
                pos,
                format!("'{name}' is already defined"),
            ));
        }
        Ok(())
    }

    fn resolve(&self, t: &Target, scope: &Scope) -> Result<ResolvedTarget, PdeTextError> {
        Ok(match t {
            Target::Name(n, _) => ResolvedTarget::Name(n.clone()),
            Target::Moment(l, m, _) => {
                let (l, m) = self.moment_label(l, m, scope)?;
                ResolvedTarget::Label(l, m)
            }
        })
    }

    fn moment_label(&self, l: &Ast, m: &Ast, scope: &Scope) -> Result<(i64, i64), PdeTextError> {
        let (lv, mv) = (self.int(l, scope)?, self.int(m, scope)?);
        if lv < 0 || mv.abs() > lv {
            return Err(PdeTextError::at(
                l.pos(),
                format!("L({lv}, {mv}) is not a moment: l ≥ 0 and −l ≤ m ≤ l"),
            ));
        }
        Ok((lv, mv))
    }

    /// An integer-valued constant expression.
    fn int(&self, e: &Ast, scope: &Scope) -> Result<i64, PdeTextError> {
        let v = self.scalar(e, scope, 0)?;
        let x = const_value(&v)
            .ok_or_else(|| PdeTextError::at(e.pos(), "an index or bound must be a constant"))?;
        if x.fract() != 0.0 || !x.is_finite() || x.abs() > 1e9 {
            return Err(PdeTextError::at(
                e.pos(),
                format!("an index or bound must be an integer, got {x}"),
            ));
        }
        Ok(x as i64)
    }

    fn scalar(&self, e: &Ast, scope: &Scope, depth: usize) -> Result<Expr, PdeTextError> {
        match self.value(e, scope, depth)? {
            Val::S(x) => Ok(x),
            Val::V(_) => Err(PdeTextError::at(
                e.pos(),
                "a vector (from grad) where a scalar is expected; take its div",
            )),
        }
    }

    fn value(&self, e: &Ast, scope: &Scope, depth: usize) -> Result<Val, PdeTextError> {
        if depth > MAX_DEPTH {
            return Err(PdeTextError::at(
                e.pos(),
                "definitions nest too deeply (a definition that uses itself?)",
            ));
        }
        Ok(match e {
            Ast::Num(s, pos) => Val::S(Expr::Num(parse_decimal(s, *pos)?)),
            Ast::Ident(name, pos) => self.ident(name, *pos, scope, depth)?,
            Ast::Neg(a, _) => match self.value(a, scope, depth)? {
                Val::S(x) => Val::S(x.neg()),
                Val::V(v) => Val::V(v.map(Expr::neg)),
            },
            Ast::Bin(op, a, b, pos) => {
                let (x, y) = (self.value(a, scope, depth)?, self.value(b, scope, depth)?);
                binary(*op, x, y, *pos)?
            }
            Ast::Sum {
                var,
                lo,
                hi,
                body,
                pos,
            } => {
                let (a, b) = (self.int(lo, scope)?, self.int(hi, scope)?);
                if b - a >= MAX_ITER {
                    return Err(PdeTextError::at(
                        *pos,
                        format!("the sum over {a}..{b} has more than {MAX_ITER} terms"),
                    ));
                }
                let mut acc: Option<Val> = None;
                for v in a..=b {
                    let mut inner = scope.clone();
                    inner
                        .vars
                        .insert(var.clone(), Val::S(Expr::Num(Surd::from_int(v))));
                    let t = self.value(body, &inner, depth + 1)?;
                    acc = Some(match acc {
                        None => t,
                        Some(s) => binary(BinOp::Add, s, t, *pos)?,
                    });
                }
                acc.unwrap_or(Val::S(Expr::int(0)))
            }
            Ast::Call(name, args, pos) => self.call(name, args, *pos, scope, depth)?,
        })
    }

    fn ident(
        &self,
        name: &str,
        pos: Pos,
        scope: &Scope,
        depth: usize,
    ) -> Result<Val, PdeTextError> {
        if let Some(v) = scope.vars.get(name) {
            return Ok(v.clone());
        }
        if let Some((_, v)) = self.params.iter().find(|(n, _)| n == name) {
            return Ok(Val::S(v.clone()));
        }
        if let Some((args, body)) = self.lets.get(name) {
            if !args.is_empty() {
                return Err(PdeTextError::at(
                    pos,
                    format!("{name} takes {} argument(s): write {name}(…)", args.len()),
                ));
            }
            return self.value(body, scope, depth + 1);
        }
        if let Some(&(l, m)) = self.labels.get(name) {
            return Ok(Val::S(Expr::moment(l, m)));
        }
        if self.labels.is_empty() && self.decls.iter().any(|d| d.name == name) {
            // First pass: unknowns are only referenced by equations, lowered later.
            return Err(PdeTextError::at(
                pos,
                format!("unknown {name} used before the equations"),
            ));
        }
        Ok(Val::S(match name {
            "sigma_t" => Expr::field(FieldName::SigmaT),
            "sigma_s" => Expr::field(FieldName::SigmaS),
            "sigma_a" => Expr::field(FieldName::SigmaA),
            "pi" => Expr::sym("pi"),
            "L" | "Q" | "phase" | "dx" | "dy" | "dz" | "grad" | "div" | "lap" | "exp" | "ln"
            | "sqrt" | "sin" | "cos" | "abs" | "dn" => {
                return Err(PdeTextError::at(
                    pos,
                    format!("{name} needs arguments: {name}(…)"),
                ))
            }
            _ => {
                return Err(PdeTextError::at(
                    pos,
                    format!(
                        "unknown symbol '{name}' (not an unknown, parameter, definition or loop \
                         variable; the fields are sigma_t, sigma_s, sigma_a, phase(l), Q(l, m))"
                    ),
                ))
            }
        }))
    }

    fn call(
        &self,
        name: &str,
        args: &[Ast],
        pos: Pos,
        scope: &Scope,
        depth: usize,
    ) -> Result<Val, PdeTextError> {
        let arity = |n: usize| -> Result<(), PdeTextError> {
            if args.len() == n {
                Ok(())
            } else {
                Err(PdeTextError::at(
                    pos,
                    format!("{name} takes {n} argument(s), got {}", args.len()),
                ))
            }
        };
        if let Some((params, body)) = self.lets.get(name) {
            if params.len() != args.len() {
                return Err(PdeTextError::at(
                    pos,
                    format!(
                        "{name} takes {} argument(s), got {}",
                        params.len(),
                        args.len()
                    ),
                ));
            }
            let mut inner = scope.clone();
            for (p, a) in params.iter().zip(args) {
                inner
                    .vars
                    .insert(p.clone(), self.value(a, scope, depth + 1)?);
            }
            return self.value(body, &inner, depth + 1);
        }
        let deriv = |axis: Axis| -> Result<Val, PdeTextError> {
            arity(1)?;
            Ok(Val::S(self.scalar(&args[0], scope, depth)?.deriv(axis)))
        };
        let grad = |e: &Ast| -> Result<[Expr; 3], PdeTextError> {
            let u = self.scalar(e, scope, depth)?;
            Ok([Axis::X, Axis::Y, Axis::Z].map(|a| u.clone().deriv(a)))
        };
        let div = |v: [Expr; 3]| -> Expr {
            Expr::add(
                v.into_iter()
                    .zip([Axis::X, Axis::Y, Axis::Z])
                    .map(|(c, a)| c.deriv(a))
                    .collect(),
            )
        };
        Ok(match name {
            "L" => {
                arity(2)?;
                let (l, m) = self.moment_label(&args[0], &args[1], scope)?;
                if !self.labels.is_empty() && !self.labels.values().any(|&lm| lm == (l, m)) {
                    return Err(PdeTextError::at(
                        pos,
                        format!(
                            "L({l}, {m}) is not an unknown of the system (declare it with \
                             `unknown NAME = L({l}, {m})` or include pn(N) with N ≥ {l})"
                        ),
                    ));
                }
                Val::S(Expr::moment(l, m))
            }
            "Q" => {
                arity(2)?;
                let (l, m) = self.moment_label(&args[0], &args[1], scope)?;
                Val::S(Expr::source(l, m))
            }
            "phase" => {
                arity(1)?;
                let l = self.int(&args[0], scope)?;
                if l < 0 {
                    return Err(PdeTextError::at(args[0].pos(), format!("phase({l}): the band must be ≥ 0")));
                }
                Val::S(Expr::field(FieldName::PhaseMoment(Box::new(Expr::Int(l)))))
            }
            "dn" => {
                arity(1)?;
                if !scope.boundary {
                    return Err(PdeTextError::at(
                        pos,
                        "dn(…), the outward normal derivative, is allowed in boundary statements only",
                    ));
                }
                let x = self.scalar(&args[0], scope, depth)?;
                Val::S(Expr::Func("dn".into(), vec![x]))
            }
            "dx" => deriv(Axis::X)?,
            "dy" => deriv(Axis::Y)?,
            "dz" => deriv(Axis::Z)?,
            "grad" => {
                arity(1)?;
                Val::V(grad(&args[0])?)
            }
            "div" => {
                arity(1)?;
                match self.value(&args[0], scope, depth)? {
                    Val::V(v) => Val::S(div(v)),
                    Val::S(_) => {
                        return Err(PdeTextError::at(
                            args[0].pos(),
                            "div takes a vector (such as D*grad(u)), got a scalar",
                        ))
                    }
                }
            }
            "lap" => {
                arity(1)?;
                Val::S(div(grad(&args[0])?))
            }
            "sqrt" => {
                arity(1)?;
                Val::S(self.scalar(&args[0], scope, depth)?.sqrt())
            }
            "exp" | "ln" | "sin" | "cos" | "abs" => {
                arity(1)?;
                let x = self.scalar(&args[0], scope, depth)?;
                match const_value(&x).and_then(|v| math(name, v)) {
                    Some(v) if v.is_finite() => Val::S(Expr::Func(name.into(), vec![x])),
                    Some(v) => {
                        return Err(PdeTextError::at(pos, format!("{name}(…) is {v} here")))
                    }
                    None => {
                        return Err(PdeTextError::at(
                            pos,
                            format!("{name} applies to constants only (the PDE must stay linear with polynomial coefficients)"),
                        ))
                    }
                }
            }
            _ => {
                return Err(PdeTextError::at(
                    pos,
                    format!("unknown function '{name}' (built-in: L, Q, phase, dx, dy, dz, grad, div, lap, dn, sum, exp, ln, sqrt, sin, cos, abs)"),
                ))
            }
        })
    }

    /// Labels the unknowns, lowers the equations and assembles the system.
    fn finish(mut self) -> Result<TextPde, PdeTextError> {
        // Unknowns in declaration order, the P_N ones at the include.
        let mut unknowns: Vec<TextUnknown> = Vec::new();
        let pn_unknowns: Vec<TextUnknown> = self
            .pn
            .as_ref()
            .map(|(sys, pos)| {
                sys.equations
                    .iter()
                    .map(|e| TextUnknown {
                        name: format!("L({}, {})", e.l, e.m),
                        label: (e.l, e.m),
                        radiance: true,
                        at: None,
                        pos: *pos,
                    })
                    .collect()
            })
            .unwrap_or_default();
        for (i, d) in self.decls.iter().enumerate() {
            if i == self.pn_at {
                unknowns.extend(pn_unknowns.iter().cloned());
            }
            if let Some(lm) = d.moment {
                if let Some(u) = unknowns.iter().find(|u| u.label == lm) {
                    return Err(PdeTextError::at(
                        d.pos,
                        format!(
                            "{} and {} both stand for L({}, {})",
                            d.name, u.name, lm.0, lm.1
                        ),
                    ));
                }
            }
            unknowns.push(TextUnknown {
                name: d.name.clone(),
                label: d.moment.unwrap_or((-1, 0)),
                radiance: d.moment.is_some(),
                at: d.at,
                pos: d.pos,
            });
        }
        if self.pn_at >= self.decls.len() {
            unknowns.extend(pn_unknowns.iter().cloned());
        }
        for u in &unknowns {
            if u.radiance {
                if let Some(d) = self
                    .decls
                    .iter()
                    .find(|d| d.moment == Some(u.label) && d.name != u.name)
                {
                    return Err(PdeTextError::at(
                        d.pos,
                        format!(
                            "{} stands for {}, which include pn already declares",
                            d.name, u.name
                        ),
                    ));
                }
            }
        }
        // Auxiliary labels: beyond the highest radiance band, l+m even (kept in 2D).
        let lmax = unknowns
            .iter()
            .filter(|u| u.radiance)
            .map(|u| u.label.0)
            .max()
            .unwrap_or(-1);
        let mut free = (lmax + 1..)
            .flat_map(|l| (-l..=l).map(move |m| (l, m)))
            .filter(|(l, m)| (l + m) % 2 == 0);
        for u in unknowns.iter_mut().filter(|u| !u.radiance) {
            u.label = free.next().unwrap_or((0, 0));
        }
        self.labels = unknowns.iter().map(|u| (u.name.clone(), u.label)).collect();

        let label_of = |t: &ResolvedTarget, pos: Pos| -> Result<(i64, i64), PdeTextError> {
            match t {
                ResolvedTarget::Name(n) => self.labels.get(n).copied().ok_or_else(|| {
                    PdeTextError::at(
                        pos,
                        format!("'{n}' is not an unknown (declare it with `unknown {n}`)"),
                    )
                }),
                ResolvedTarget::Label(l, m) => {
                    if self.labels.values().any(|&lm| lm == (*l, *m)) {
                        Ok((*l, *m))
                    } else {
                        Err(PdeTextError::at(
                            pos,
                            format!("L({l}, {m}) is not an unknown of the system"),
                        ))
                    }
                }
            }
        };

        // Equations: the derived P_N ones, then the written ones.
        let mut eqs: Vec<(PdeEquation, Pos)> = Vec::new();
        if let Some((sys, pos)) = &self.pn {
            for e in &sys.equations {
                eqs.push((
                    PdeEquation {
                        l: e.l,
                        m: e.m,
                        lhs: e.lhs.clone(),
                        rhs: e.rhs.clone(),
                    },
                    *pos,
                ));
            }
        }
        for pe in &self.equations {
            let (l, m) = label_of(&pe.target, pe.pos)?;
            if let Some((_, p)) = eqs.iter().find(|(e, _)| (e.l, e.m) == (l, m)) {
                return Err(PdeTextError::at(
                    pe.pos,
                    format!(
                        "a second equation located at {} (the first is on line {}): the system must have one equation per unknown",
                        self.name_of((l, m)),
                        p.line
                    ),
                ));
            }
            let lhs = self.scalar(&pe.lhs, &pe.scope, 0)?;
            let rhs = self.scalar(&pe.rhs, &pe.scope, 0)?;
            eqs.push((PdeEquation { l, m, lhs, rhs }, pe.pos));
        }
        for pa in &self.adds {
            let (l, m) = label_of(&pa.target, pa.pos)?;
            let term = self.scalar(&pa.term, &pa.scope, 0)?;
            let Some((eq, _)) = eqs.iter_mut().find(|(e, _)| (e.l, e.m) == (l, m)) else {
                return Err(PdeTextError::at(
                    pa.pos,
                    format!("add: {} has no equation to add to", self.name_of((l, m))),
                ));
            };
            eq.lhs = Expr::add(vec![eq.lhs.clone(), term]);
        }
        // Eliminations: each unknown solved from its own equation and substituted.
        for (target, pos) in &self.eliminations {
            let lm = label_of(target, *pos)?;
            let name = self.name_of(lm);
            let Some(k) = eqs.iter().position(|(e, _)| (e.l, e.m) == lm) else {
                return Err(PdeTextError::at(
                    *pos,
                    format!(
                        "eliminate: {name} has no equation to solve for it (eliminated twice?)"
                    ),
                ));
            };
            let (eq, eq_pos) = eqs.remove(k);
            let value = solve_for(&Expr::add(vec![eq.lhs, eq.rhs.neg()]), lm).map_err(|m| {
                PdeTextError::at(
                    *pos,
                    format!(
                        "eliminate {name}: {m} (its equation, line {}, must read c*{name} + \
                         terms without {name} = 0, c free of unknowns)",
                        eq_pos.line
                    ),
                )
            })?;
            let subst = |e: &Expr| {
                e.rewrite_bottom_up(&mut |x| {
                    if crate::pde::as_unknown(&x) == Some(lm) {
                        value.clone()
                    } else {
                        x
                    }
                })
            };
            for (e, _) in eqs.iter_mut() {
                e.lhs = subst(&e.lhs);
                e.rhs = subst(&e.rhs);
            }
            unknowns.retain(|u| u.label != lm);
        }
        let boundaries = self.lower_boundaries(&unknowns, &label_of)?;
        // Systems order equations like their unknowns.
        let mut ordered = Vec::with_capacity(eqs.len());
        for u in &unknowns {
            if let Some(i) = eqs.iter().position(|(e, _)| (e.l, e.m) == u.label) {
                ordered.push(eqs.swap_remove(i));
            }
        }
        let params = self
            .params
            .iter()
            .map(|(n, e)| (n.clone(), const_value(e).unwrap_or(f64::NAN)))
            .collect();
        Ok(TextPde {
            system: PdeSystem {
                name: self.name.clone().unwrap_or_else(|| "user".into()),
                dim: Dim::Three,
                unknowns: unknowns.iter().map(|u| u.label).collect(),
                equations: ordered.iter().map(|(e, _)| e.clone()).collect(),
            },
            equation_pos: ordered.iter().map(|(_, p)| *p).collect(),
            unknowns,
            params,
            boundaries,
        })
    }

    /// Lowers the `boundary` statements: one linear condition per (kind, unknown), every
    /// unknown closed once a kind has conditions at all (they are square, like the system).
    fn lower_boundaries(
        &self,
        unknowns: &[TextUnknown],
        label_of: &LabelOf<'_>,
    ) -> Result<Vec<TextBoundary>, PdeTextError> {
        let mut out: Vec<TextBoundary> = Vec::new();
        for pb in &self.boundaries {
            let target = label_of(&pb.target, pb.target_pos)?;
            if !unknowns.iter().any(|u| u.label == target) {
                return Err(PdeTextError::at(
                    pb.target_pos,
                    format!(
                        "{} was eliminated: it has no boundary condition",
                        self.name_of(target)
                    ),
                ));
            }
            if let Some(b) = out.iter().find(|b| b.kind == pb.kind && b.target == target) {
                return Err(PdeTextError::at(
                    pb.pos,
                    format!(
                        "a second `boundary {}` condition for {} (the first is on line {})",
                        pb.kind,
                        self.name_of(target),
                        b.pos.line
                    ),
                ));
            }
            let lhs = self.scalar(&pb.lhs, &pb.scope, 0)?;
            let rhs = self.scalar(&pb.rhs, &pb.scope, 0)?;
            let form = split_boundary(&Expr::add(vec![lhs, rhs.neg()]), false)
                .map_err(|m| PdeTextError::at(pb.pos, m))?;
            if form.rest.iter().any(|e| const_value(e) != Some(0.0)) {
                return Err(PdeTextError::at(
                    pb.pos,
                    "a boundary condition must be homogeneous (every term a coefficient times an \
                     unknown or dn(unknown), = 0): it has a term without an unknown",
                ));
            }
            if form.normal.is_empty() {
                return Err(PdeTextError::at(
                    pb.pos,
                    "a boundary condition needs a normal derivative dn(…) of an unknown (it \
                     closes the flux across the face)",
                ));
            }
            out.push(TextBoundary {
                kind: pb.kind.clone(),
                target,
                value: form.value,
                normal: form.normal,
                pos: pb.pos,
            });
        }
        for kind in BOUNDARY_KINDS {
            let Some(first) = out.iter().find(|b| b.kind == kind) else {
                continue;
            };
            for u in unknowns {
                if !out.iter().any(|b| b.kind == kind && b.target == u.label) {
                    return Err(PdeTextError::at(
                        u.pos,
                        format!(
                            "unknown {} has no `boundary {kind}` condition (line {} states one; \
                             the conditions must be square: one per unknown)",
                            u.name, first.pos.line
                        ),
                    ));
                }
            }
        }
        Ok(out)
    }

    fn name_of(&self, lm: (i64, i64)) -> String {
        self.labels
            .iter()
            .find(|(_, &v)| v == lm)
            .map(|(n, _)| n.clone())
            .unwrap_or_else(|| format!("L({}, {})", lm.0, lm.1))
    }
}

/// `x op y` on scalars and vectors.
fn binary(op: BinOp, x: Val, y: Val, pos: Pos) -> Result<Val, PdeTextError> {
    use Val::{S, V};
    let bad = |what: &str| Err(PdeTextError::at(pos, what.to_string()));
    Ok(match (op, x, y) {
        (BinOp::Add, S(a), S(b)) => S(Expr::add(vec![a, b])),
        (BinOp::Sub, S(a), S(b)) => S(Expr::add(vec![a, b.neg()])),
        (BinOp::Add, V(a), V(b)) => {
            let [a0, a1, a2] = a;
            let [b0, b1, b2] = b;
            V([
                Expr::add(vec![a0, b0]),
                Expr::add(vec![a1, b1]),
                Expr::add(vec![a2, b2]),
            ])
        }
        (BinOp::Sub, V(a), V(b)) => {
            let [a0, a1, a2] = a;
            let [b0, b1, b2] = b;
            V([
                Expr::add(vec![a0, b0.neg()]),
                Expr::add(vec![a1, b1.neg()]),
                Expr::add(vec![a2, b2.neg()]),
            ])
        }
        (BinOp::Add | BinOp::Sub, _, _) => return bad("cannot add a vector and a scalar"),
        (BinOp::Mul, S(a), S(b)) => S(Expr::mul(vec![a, b])),
        (BinOp::Mul, S(a), V(v)) | (BinOp::Mul, V(v), S(a)) => {
            V(v.map(|c| Expr::mul(vec![a.clone(), c])))
        }
        (BinOp::Mul, V(_), V(_)) => {
            return bad(
                "the product of two vectors is not defined (write the components with dx, dy, dz)",
            )
        }
        (BinOp::Div, S(a), S(b)) => S(Expr::mul(vec![a, b.recip()])),
        (BinOp::Div, V(v), S(b)) => V(v.map(|c| Expr::mul(vec![c, b.clone().recip()]))),
        (BinOp::Div, _, V(_)) => return bad("cannot divide by a vector"),
        (BinOp::Pow, S(a), S(b)) => S(a.pow(b)),
        (BinOp::Pow, _, _) => return bad("powers of vectors are not defined"),
    })
}

/// A boundary expression split into `Σ value_j u_j + Σ normal_k dn(u_k) + Σ rest`.
#[derive(Default)]
struct BoundaryForm {
    value: Vec<((i64, i64), Expr)>,
    normal: Vec<((i64, i64), Expr)>,
    rest: Vec<Expr>,
}

impl BoundaryForm {
    fn add(mut self, o: BoundaryForm) -> BoundaryForm {
        self.value.extend(o.value);
        self.normal.extend(o.normal);
        self.rest.extend(o.rest);
        self
    }
    fn scale(self, c: &Expr) -> BoundaryForm {
        let sc = |v: Vec<((i64, i64), Expr)>| {
            v.into_iter()
                .map(|(lm, e)| (lm, Expr::mul(vec![c.clone(), e])))
                .collect()
        };
        BoundaryForm {
            value: sc(self.value),
            normal: sc(self.normal),
            rest: self
                .rest
                .into_iter()
                .map(|e| Expr::mul(vec![c.clone(), e]))
                .collect(),
        }
    }
}

/// Whether `e` mentions an unknown or `dn`.
fn mentions_unknown(e: &Expr) -> bool {
    e.any(&|x| crate::pde::as_unknown(x).is_some() || matches!(x, Expr::Func(f, _) if f == "dn"))
}

/// Splits a lowered boundary expression into its linear parts (coefficients are left as
/// `cas` expressions); `in_dn`: inside `dn(…)`.
fn split_boundary(e: &Expr, in_dn: bool) -> Result<BoundaryForm, String> {
    if let Some(lm) = crate::pde::as_unknown(e) {
        let one = vec![(lm, Expr::int(1))];
        return Ok(if in_dn {
            BoundaryForm {
                normal: one,
                ..Default::default()
            }
        } else {
            BoundaryForm {
                value: one,
                ..Default::default()
            }
        });
    }
    if !mentions_unknown(e) {
        if e.any(&|x| matches!(x, Expr::Deriv(..))) {
            return Err(derivative_message());
        }
        if in_dn {
            return Err(
                "dn(…) applies to unknowns (the normal derivative of a coefficient \
                        is not part of a boundary condition)"
                    .into(),
            );
        }
        return Ok(BoundaryForm {
            rest: vec![e.clone()],
            ..Default::default()
        });
    }
    match e {
        Expr::Add(ts) => {
            let mut acc = BoundaryForm::default();
            for t in ts {
                acc = acc.add(split_boundary(t, in_dn)?);
            }
            Ok(acc)
        }
        Expr::Mul(fs) => {
            let mut linear: Option<BoundaryForm> = None;
            let mut coeff = Vec::new();
            for f in fs {
                if mentions_unknown(f) {
                    if linear.is_some() {
                        return Err(
                            "a product of unknowns (a boundary condition must be linear)".into(),
                        );
                    }
                    linear = Some(split_boundary(f, in_dn)?);
                } else {
                    if f.any(&|x| matches!(x, Expr::Deriv(..))) {
                        return Err(derivative_message());
                    }
                    coeff.push(f.clone());
                }
            }
            let linear = linear.unwrap_or_default();
            Ok(linear.scale(&Expr::mul(coeff)))
        }
        Expr::Func(f, args) if f == "dn" && args.len() == 1 => {
            if in_dn {
                return Err(
                    "dn(dn(…)): a boundary condition takes first normal derivatives only".into(),
                );
            }
            let inner = split_boundary(&args[0], true)?;
            if inner.normal.iter().any(|(_, c)| const_value(c).is_none()) {
                return Err(
                    "dn(…) takes unknowns with constant coefficients (dn(c*u) with a \
                            field c is not c*dn(u)); write the coefficient outside: c*dn(u)"
                        .into(),
                );
            }
            if !inner.rest.is_empty() {
                return Err(
                    "dn(…) applies to unknowns (the normal derivative of a coefficient \
                            is not part of a boundary condition)"
                        .into(),
                );
            }
            Ok(inner)
        }
        Expr::Deriv(..) => Err(derivative_message()),
        _ => Err(
            "an unknown inside a power or function (a boundary condition must be linear)".into(),
        ),
    }
}

fn derivative_message() -> String {
    "derivatives in a boundary condition are written dn(…), the outward normal derivative \
     (dx, dy, dz, grad, div and lap are not allowed there)"
        .into()
}

/// Solves the expression `e = 0` for the unknown `lm`: `e` must be `c·lm + rest` with `c`
/// and `rest` free of `lm` and `lm` not under a derivative; returns `−rest / c`.
fn solve_for(e: &Expr, lm: (i64, i64)) -> Result<Expr, String> {
    /// The terms of `e` with `lm` (their coefficients) and without it.
    fn split(e: &Expr, lm: (i64, i64)) -> Result<(Vec<Expr>, Vec<Expr>), String> {
        let has = |x: &Expr| x.any(&|y| crate::pde::as_unknown(y) == Some(lm));
        if crate::pde::as_unknown(e) == Some(lm) {
            return Ok((vec![Expr::int(1)], Vec::new()));
        }
        if !has(e) {
            return Ok((Vec::new(), vec![e.clone()]));
        }
        match e {
            Expr::Add(ts) => {
                let (mut c, mut r) = (Vec::new(), Vec::new());
                for t in ts {
                    let (ct, rt) = split(t, lm)?;
                    c.extend(ct);
                    r.extend(rt);
                }
                Ok((c, r))
            }
            Expr::Mul(fs) => {
                let mut inner = None;
                let mut others = Vec::new();
                for f in fs {
                    if has(f) {
                        if inner.is_some() {
                            return Err("it appears in a product with itself".into());
                        }
                        inner = Some(split(f, lm)?);
                    } else {
                        others.push(f.clone());
                    }
                }
                let (c, r) = inner.unwrap_or_default();
                let scale = |v: Vec<Expr>| -> Vec<Expr> {
                    v.into_iter()
                        .map(|x| {
                            let mut fs = others.clone();
                            fs.push(x);
                            Expr::mul(fs)
                        })
                        .collect()
                };
                Ok((scale(c), scale(r)))
            }
            Expr::Deriv(..) => Err("it is differentiated in its own equation".into()),
            _ => Err("it appears inside a power or function".into()),
        }
    }
    let (c, rest) = split(e, lm)?;
    if c.is_empty() {
        return Err("its own equation does not contain it".into());
    }
    let c = Expr::add(c);
    if c.any(&|y| crate::pde::as_unknown(y).is_some()) {
        return Err("its coefficient contains an unknown".into());
    }
    if const_value(&c) == Some(0.0) {
        return Err("its coefficient is zero".into());
    }
    Ok(Expr::mul(vec![Expr::add(rest).neg(), c.recip()]))
}
