//! Lowering of parsed statements into a [`PdeSystem`](crate::pde::PdeSystem) of `cas`
//! expressions: loops expanded, definitions substituted, unknowns labelled, `grad`/`div`
//! written out as partial derivatives.
//!
//! This module runs the statements ([`lower`]: declarations, definitions, loops; equations,
//! additions and boundary conditions are kept for later); [`eval`] lowers expressions,
//! [`assemble`] labels the unknowns and assembles the system (equations, additions,
//! eliminations) and [`boundary`] lowers the boundary conditions.

mod assemble;
mod boundary;
mod eval;

use std::collections::HashMap;

use cas::{Expr, Surd};

use super::lex::Pos;
use super::parse::{Ast, Stmt, Target};
use super::{PdeTextError, TextPde};
use eval::{const_value, parse_decimal};

/// Nesting limit for definitions (catches `let a = a`).
const MAX_DEPTH: usize = 64;
/// Largest number of loop iterations or sum terms (catches typos such as `0..1000000`).
const MAX_ITER: i64 = 10_000;
/// Largest number of expression nodes lowered in all (definitions substituted, sums and
/// loops expanded): bounds the work of nested loops and of definitions that double at each
/// level (`let b = a + a`, `let c = b + b`, …), which the per-level limits do not.
const MAX_NODES: usize = 5_000_000;
/// Deepest recursion of the lowering: expression nesting (at most the parser's 100 levels)
/// times the definitions substituted into each other (each `let` may nest again). Beyond it
/// the lowering, and the `cas` passes after it, would overflow the stack.
const MAX_LEVELS: usize = 200;
/// Most derivatives nested along one path of an expression (`lap(lap(u))` is 4): the
/// discretization's terms double with each, so `dx` nested 30 times would never finish.
const MAX_DERIVATIVES: usize = 8;
/// Largest number of statements run, loops expanded (nested loops multiply their ranges).
const MAX_STATEMENTS: usize = 1_000_000;

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
    /// Expression nodes lowered so far (see [`MAX_NODES`]).
    nodes: std::cell::Cell<usize>,
    /// The current recursion depth of the lowering (see [`MAX_LEVELS`]).
    levels: std::cell::Cell<usize>,
    /// Statements run so far (see [`MAX_STATEMENTS`]).
    statements: usize,
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

impl Lowerer {
    fn execute(
        &mut self,
        s: &Stmt,
        scope: &Scope,
        overrides: &mut Vec<&(String, String)>,
    ) -> Result<(), PdeTextError> {
        self.statements += 1;
        if self.statements > MAX_STATEMENTS {
            let (Stmt::Pde(_, pos)
            | Stmt::Param(_, _, pos)
            | Stmt::Let(_, _, _, pos)
            | Stmt::Unknown { pos, .. }
            | Stmt::Equation(_, _, _, pos)
            | Stmt::AddTerm(_, _, pos)
            | Stmt::Eliminate(_, pos)
            | Stmt::IncludePn(_, pos)
            | Stmt::Boundary { pos, .. }
            | Stmt::For(_, _, pos)) = s;
            return Err(PdeTextError::at(
                *pos,
                format!("the loops run more than {MAX_STATEMENTS} statements"),
            ));
        }
        match s {
            Stmt::Pde(name, pos) => {
                if self.name.is_some() {
                    return Err(PdeTextError::at(*pos, "a second 'pde' statement"));
                }
                self.name = Some(name.clone());
            }
            Stmt::Param(name, e, pos) => self.param(name, e, *pos, scope, overrides)?,
            Stmt::Let(name, args, body, pos) => {
                self.check_new_name(name, *pos)?;
                self.lets.insert(name.clone(), (args.clone(), body.clone()));
            }
            Stmt::Unknown {
                name,
                moment,
                at,
                pos,
            } => self.declare_unknown(name, moment.as_ref(), at.as_ref(), *pos, scope)?,
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
                kind,
                target,
                lhs,
                rhs,
                pos,
            } => self.boundary(kind, target, lhs, rhs, *pos, scope)?,
            Stmt::Eliminate(target, _) => {
                let pos = match target {
                    Target::Name(_, p) | Target::Moment(_, _, p) => *p,
                };
                let target = self.resolve(target, scope)?;
                self.eliminations.push((target, pos));
            }
            Stmt::IncludePn(n, pos) => self.include_pn(n, *pos, scope)?,
            Stmt::For(ranges, body, _) => self.run_loop(ranges, 0, body, scope, overrides)?,
        }
        Ok(())
    }

    /// `param NAME = e`, or the value `--pde-param NAME=VALUE` gives it.
    fn param(
        &mut self,
        name: &str,
        e: &Ast,
        pos: Pos,
        scope: &Scope,
        overrides: &mut Vec<&(String, String)>,
    ) -> Result<(), PdeTextError> {
        self.check_new_name(name, pos)?;
        let value = match overrides.iter().position(|(n, _)| n == name) {
            Some(i) => {
                let (_, v) = overrides.remove(i);
                let v = v.trim();
                let (neg, digits) = match v.strip_prefix('-') {
                    Some(d) => (true, d),
                    None => (false, v),
                };
                let s = parse_decimal(digits, pos).map_err(|_| {
                    PdeTextError::at(pos, format!("--pde-param {name}={v}: not a decimal number"))
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
        self.params.push((name.to_string(), value));
        Ok(())
    }

    /// `unknown NAME [= L(l, m)] [at (sx, sy, sz)]`.
    fn declare_unknown(
        &mut self,
        name: &str,
        moment: Option<&(Ast, Ast)>,
        at: Option<&[Ast; 3]>,
        pos: Pos,
        scope: &Scope,
    ) -> Result<(), PdeTextError> {
        if let Some(d) = self.decls.iter().find(|d| d.name == *name) {
            return Err(PdeTextError::at(
                pos,
                format!(
                    "unknown {name} is declared twice (first on line {})",
                    d.pos.line
                ),
            ));
        }
        self.check_new_name(name, pos)?;
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
            name: name.to_string(),
            moment,
            at,
            pos,
        });
        Ok(())
    }

    /// `boundary KIND TARGET: lhs = rhs`, lowered once the unknowns are labelled.
    fn boundary(
        &mut self,
        (kind, kind_pos): &(String, Pos),
        target: &Target,
        lhs: &Ast,
        rhs: &Ast,
        pos: Pos,
        scope: &Scope,
    ) -> Result<(), PdeTextError> {
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
            pos,
        });
        Ok(())
    }

    /// `include pn(N)`: the derived P_N system, its unknowns inserted here.
    fn include_pn(&mut self, n: &Ast, pos: Pos, scope: &Scope) -> Result<(), PdeTextError> {
        if self.pn.is_some() {
            return Err(PdeTextError::at(pos, "pn(N) is included twice"));
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
            .map_err(|e| PdeTextError::at(pos, format!("deriving P_{order}: {e}")))?;
        self.pn = Some((sys, pos));
        self.pn_at = self.decls.len();
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
        if lv > pn_stencil::MAX_ORDER as i64 {
            return Err(PdeTextError::at(
                l.pos(),
                format!(
                    "L({lv}, {mv}): the order l = {lv} is above the largest supported, {}",
                    pn_stencil::MAX_ORDER
                ),
            ));
        }
        Ok((lv, mv))
    }

    fn name_of(&self, lm: (i64, i64)) -> String {
        self.labels
            .iter()
            .find(|(_, &v)| v == lm)
            .map(|(n, _)| n.clone())
            .unwrap_or_else(|| format!("L({}, {})", lm.0, lm.1))
    }
}
