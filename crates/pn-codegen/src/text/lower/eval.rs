//! Expressions: numbers, names (loop variables, parameters, definitions, unknowns,
//! fields), operators, `sum` and the built-in functions, lowered to `cas` expressions.

use cas::{Axis, Expr, FieldName, Surd};
use num_rational::Rational64;

use super::{Lowerer, Scope, Val, MAX_DEPTH, MAX_DERIVATIVES, MAX_ITER, MAX_LEVELS, MAX_NODES};
use crate::discretize::math;
use crate::text::lex::Pos;
use crate::text::parse::{Ast, BinOp};
use crate::text::PdeTextError;

/// An exact rational from a decimal literal such as `0.25` or `1e-3`.
pub(super) fn parse_decimal(s: &str, pos: Pos) -> Result<Surd, PdeTextError> {
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
    /// An integer-valued constant expression.
    pub(super) fn int(&self, e: &Ast, scope: &Scope) -> Result<i64, PdeTextError> {
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

    pub(super) fn scalar(
        &self,
        e: &Ast,
        scope: &Scope,
        depth: usize,
    ) -> Result<Expr, PdeTextError> {
        match self.value(e, scope, depth)? {
            Val::S(x) => Ok(x),
            Val::V(_) => Err(PdeTextError::at(
                e.pos(),
                "a vector (from grad) where a scalar is expected; take its div",
            )),
        }
    }

    fn value(&self, e: &Ast, scope: &Scope, depth: usize) -> Result<Val, PdeTextError> {
        let level = self.levels.get() + 1;
        if level > MAX_LEVELS {
            return Err(PdeTextError::at(
                e.pos(),
                format!(
                    "with its definitions substituted, the expression nests more than \
                     {MAX_LEVELS} levels deep"
                ),
            ));
        }
        self.levels.set(level);
        let v = self.value_at_level(e, scope, depth);
        self.levels.set(level - 1);
        v
    }

    fn value_at_level(&self, e: &Ast, scope: &Scope, depth: usize) -> Result<Val, PdeTextError> {
        if depth > MAX_DEPTH {
            return Err(PdeTextError::at(
                e.pos(),
                "definitions nest too deeply (a definition that uses itself?)",
            ));
        }
        let nodes = self.nodes.get() + 1;
        self.nodes.set(nodes);
        if nodes > MAX_NODES {
            return Err(PdeTextError::at(
                e.pos(),
                format!(
                    "the PDE expands to more than {MAX_NODES} expression nodes (definitions \
                     substituted, sums and loops expanded)"
                ),
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
            Ast::Chain(first, rest) => {
                let mut acc = Chain::new(self.value(first, scope, depth)?);
                for (op, e, pos) in rest {
                    acc.push(*op, self.value(e, scope, depth)?, *pos)?;
                }
                acc.finish()
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
                let mut acc: Option<Chain> = None;
                for v in a..=b {
                    let mut inner = scope.clone();
                    inner
                        .vars
                        .insert(var.clone(), Val::S(Expr::Num(Surd::from_int(v))));
                    let t = self.value(body, &inner, depth + 1)?;
                    match acc.as_mut() {
                        None => acc = Some(Chain::new(t)),
                        Some(c) => c.push(BinOp::Add, t, *pos)?,
                    }
                }
                acc.map_or(Val::S(Expr::int(0)), Chain::finish)
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
            let u = self.scalar(&args[0], scope, depth)?;
            Ok(Val::S(check_derivatives(u, pos)?.deriv(axis)))
        };
        let grad = |e: &Ast| -> Result<[Expr; 3], PdeTextError> {
            let u = check_derivatives(self.scalar(e, scope, depth)?, pos)?;
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
                if l > pn_stencil::MAX_ORDER as i64 {
                    return Err(PdeTextError::at(
                        args[0].pos(),
                        format!("phase({l}): the band is above the largest supported order, {}", pn_stencil::MAX_ORDER),
                    ));
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
}

/// Most derivatives nested along one path of `e`.
fn derivative_depth(e: &Expr) -> usize {
    let mut d = 0;
    e.for_each_child(&mut |c| d = d.max(derivative_depth(c)));
    d + usize::from(matches!(e, Expr::Deriv(..)))
}

/// `e`, to be differentiated once more; refused when that nests more than
/// [`MAX_DERIVATIVES`] derivatives.
fn check_derivatives(e: Expr, pos: Pos) -> Result<Expr, PdeTextError> {
    let d = derivative_depth(&e) + 1;
    if d > MAX_DERIVATIVES {
        return Err(PdeTextError::at(
            pos,
            format!("derivatives nested {d} deep, more than the {MAX_DERIVATIVES} supported"),
        ));
    }
    Ok(e)
}

/// A chain `a op b op c …` of one precedence level, gathered into one n-ary `cas` sum or
/// product (no expression nested once per term): the scalar terms or factors, and for a
/// vector the three components' terms (a sum) or the vector factor (a product).
struct Chain {
    scalars: Vec<Expr>,
    vector: Option<[Vec<Expr>; 3]>,
    /// Whether this is a product (`* /`), else a sum (`+ -`); set by the first operator.
    product: Option<bool>,
}

impl Chain {
    fn new(first: Val) -> Chain {
        match first {
            Val::S(x) => Chain {
                scalars: vec![x],
                vector: None,
                product: None,
            },
            Val::V([a, b, c]) => Chain {
                scalars: Vec::new(),
                vector: Some([vec![a], vec![b], vec![c]]),
                product: None,
            },
        }
    }

    fn push(&mut self, op: BinOp, y: Val, pos: Pos) -> Result<(), PdeTextError> {
        let bad = |what: &str| Err(PdeTextError::at(pos, what.to_string()));
        let product = matches!(op, BinOp::Mul | BinOp::Div);
        if *self.product.get_or_insert(product) != product || op == BinOp::Pow {
            // The parser never mixes precedence levels in one chain.
            return bad("internal: mixed operators in one chain");
        }
        match (op, y, self.vector.as_mut()) {
            (BinOp::Add, Val::S(b), None) => self.scalars.push(b),
            (BinOp::Sub, Val::S(b), None) => self.scalars.push(b.neg()),
            (BinOp::Add | BinOp::Sub, Val::V(v), Some(acc)) => {
                for (t, c) in acc.iter_mut().zip(v) {
                    t.push(if op == BinOp::Sub { c.neg() } else { c });
                }
            }
            (BinOp::Add | BinOp::Sub, _, _) => return bad("cannot add a vector and a scalar"),
            (BinOp::Mul, Val::S(b), _) => self.scalars.push(b),
            (BinOp::Div, Val::S(b), _) => self.scalars.push(b.recip()),
            (BinOp::Mul, Val::V(v), None) => self.vector = Some(v.map(|c| vec![c])),
            (BinOp::Mul, Val::V(_), Some(_)) => return bad(
                "the product of two vectors is not defined (write the components with dx, dy, dz)",
            ),
            (BinOp::Div | BinOp::Pow, Val::V(_), _) => return bad("cannot divide by a vector"),
            (BinOp::Pow, Val::S(_), _) => return bad("internal: a power in a chain"),
        }
        Ok(())
    }

    fn finish(self) -> Val {
        let product = self.product == Some(true);
        let join = |terms: Vec<Expr>| {
            if product {
                Expr::mul(terms)
            } else {
                Expr::add(terms)
            }
        };
        match self.vector {
            None if self.scalars.len() == 1 => Val::S(
                self.scalars
                    .into_iter()
                    .next()
                    .unwrap_or_else(|| Expr::int(0)),
            ),
            None => Val::S(join(self.scalars)),
            Some(v) if product => Val::V(v.map(|c| {
                let mut f = self.scalars.clone();
                f.extend(c);
                Expr::mul(f)
            })),
            Some(v) => Val::V(v.map(|c| {
                if c.len() == 1 {
                    c.into_iter().next().unwrap_or_else(|| Expr::int(0))
                } else {
                    Expr::add(c)
                }
            })),
        }
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
