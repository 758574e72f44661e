//! The parser of the PDE text syntax: statements and expressions (see the grammar in
//! [`super`]).

use super::lex::{Pos, Tok, Token};
use super::PdeTextError;

/// A binary operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `^`
    Pow,
}

/// An expression as written.
#[derive(Clone, Debug, PartialEq)]
pub enum Ast {
    /// A decimal literal.
    Num(String, Pos),
    /// A name.
    Ident(String, Pos),
    /// `name(args)`.
    Call(String, Vec<Ast>, Pos),
    /// `-e`.
    Neg(Box<Ast>, Pos),
    /// `a op b`.
    Bin(BinOp, Box<Ast>, Box<Ast>, Pos),
    /// A flat chain `a op b op c …` of one precedence level (`+ -` or `* /`), evaluated
    /// left to right: the first operand, then each operator with its operand and position.
    /// Kept as a list so that a sum of 100,000 terms is no tree 100,000 levels deep.
    Chain(Box<Ast>, Vec<(BinOp, Ast, Pos)>),
    /// `sum(k = lo..hi, body)`.
    Sum {
        /// The index.
        var: String,
        /// Lower bound (inclusive).
        lo: Box<Ast>,
        /// Upper bound (inclusive).
        hi: Box<Ast>,
        /// The summand.
        body: Box<Ast>,
        /// Where `sum` stands.
        pos: Pos,
    },
}

impl Ast {
    /// Where the expression starts (for operators: the operator; for a chain: its last).
    pub fn pos(&self) -> Pos {
        match self {
            Ast::Num(_, p) | Ast::Ident(_, p) | Ast::Call(_, _, p) | Ast::Neg(_, p) => *p,
            Ast::Bin(_, _, _, p) => *p,
            // The last operator, as for the left-nested tree the chain stands for.
            Ast::Chain(first, rest) => rest.last().map_or_else(|| first.pos(), |(_, _, p)| *p),
            Ast::Sum { pos, .. } => *pos,
        }
    }
}

/// What an equation or an `add` is located at: a named unknown or `L(l, m)`.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// A declared unknown's name.
    Name(String, Pos),
    /// `L(l, m)`.
    Moment(Ast, Ast, Pos),
}

/// One statement.
#[derive(Clone, Debug, PartialEq)]
pub enum Stmt {
    /// `pde NAME`
    Pde(String, Pos),
    /// `param NAME = expr` (a number; `--pde-param NAME=VALUE` overrides it).
    Param(String, Ast, Pos),
    /// `let NAME = expr` or `let NAME(a, b) = expr`.
    Let(String, Vec<String>, Ast, Pos),
    /// `unknown NAME [= L(l, m)] [at (sx, sy, sz)]`.
    Unknown {
        /// Its name.
        name: String,
        /// The radiance moment it stands for, if any.
        moment: Option<(Ast, Ast)>,
        /// An explicit placement (half-cell shifts), checked against the derived one.
        at: Option<[Ast; 3]>,
        /// Where the statement is.
        pos: Pos,
    },
    /// `equation TARGET: lhs = rhs`.
    Equation(Target, Ast, Ast, Pos),
    /// `add TARGET: expr` (adds to the left-hand side of TARGET's equation).
    AddTerm(Target, Ast, Pos),
    /// `eliminate TARGET`: TARGET's equation, algebraic in TARGET, solved for it and
    /// substituted into the other equations; the unknown and its equation leave the system.
    Eliminate(Target, Pos),
    /// `include pn(N)`: the derived P_N unknowns and equations.
    IncludePn(Ast, Pos),
    /// `boundary KIND TARGET: lhs = rhs`: a boundary condition of the kind KIND (`marshak`)
    /// stated for the unknown TARGET; `dn(e)` is the outward normal derivative.
    Boundary {
        /// The boundary kind and where it is written.
        kind: (String, Pos),
        /// The unknown the condition is stated for.
        target: Target,
        /// Left-hand side.
        lhs: Ast,
        /// Right-hand side.
        rhs: Ast,
        /// Where the statement is.
        pos: Pos,
    },
    /// `for v = lo..hi [, w = lo..hi]: statement`.
    For(Vec<(String, Ast, Ast)>, Box<Stmt>, Pos),
}

/// The deepest nesting the parser accepts: parentheses, function calls, unary signs, powers
/// and `for` statements, each one level. The parser and the lowering recurse once per level;
/// this bound keeps them far from the stack's end (no PDE needs more than a handful).
pub const MAX_NESTING: usize = 100;

/// Parses the token stream into statements.
pub fn parse(tokens: &[Token]) -> Result<Vec<Stmt>, PdeTextError> {
    let mut p = Parser {
        tokens,
        i: 0,
        depth: 0,
    };
    let mut out = Vec::new();
    while p.i < tokens.len() {
        if p.peek_is_end() {
            p.i += 1;
            continue;
        }
        let s = p.statement()?;
        p.expect_end()?;
        out.push(s);
    }
    Ok(out)
}

struct Parser<'a> {
    tokens: &'a [Token],
    i: usize,
    /// The current nesting (see [`MAX_NESTING`]).
    depth: usize,
}

const KEYWORDS: [&str; 10] = [
    "pde",
    "param",
    "let",
    "unknown",
    "equation",
    "add",
    "boundary",
    "eliminate",
    "include",
    "for",
];

impl Parser<'_> {
    fn peek(&self) -> &Token {
        // The tokenizer always ends with `End`.
        &self.tokens[self.i.min(self.tokens.len() - 1)]
    }
    fn pos(&self) -> Pos {
        self.peek().pos
    }
    fn peek_is_end(&self) -> bool {
        matches!(self.peek().tok, Tok::End)
    }
    fn describe(t: &Tok) -> String {
        match t {
            Tok::Ident(s) => format!("'{s}'"),
            Tok::Number(s) => format!("the number {s}"),
            Tok::Op(o) => format!("'{o}'"),
            Tok::End => "the end of the statement".into(),
        }
    }
    fn is_op(&self, op: &str) -> bool {
        matches!(self.peek().tok, Tok::Op(o) if o == op)
    }
    fn eat_op(&mut self, op: &str) -> bool {
        if self.is_op(op) {
            self.i += 1;
            true
        } else {
            false
        }
    }
    fn expect_op(&mut self, op: &str, context: &str) -> Result<(), PdeTextError> {
        if self.eat_op(op) {
            Ok(())
        } else {
            Err(PdeTextError::at(
                self.pos(),
                format!(
                    "expected '{op}' {context}, found {}",
                    Self::describe(&self.peek().tok)
                ),
            ))
        }
    }
    fn expect_end(&mut self) -> Result<(), PdeTextError> {
        if self.peek_is_end() {
            self.i += 1;
            Ok(())
        } else {
            Err(PdeTextError::at(
                self.pos(),
                format!(
                    "expected the end of the statement, found {}",
                    Self::describe(&self.peek().tok)
                ),
            ))
        }
    }
    fn ident(&mut self, what: &str) -> Result<(String, Pos), PdeTextError> {
        let t = self.peek().clone();
        match t.tok {
            Tok::Ident(s) => {
                self.i += 1;
                Ok((s, t.pos))
            }
            other => Err(PdeTextError::at(
                t.pos,
                format!("expected {what}, found {}", Self::describe(&other)),
            )),
        }
    }
    /// Enters one nesting level; an error at the current token past [`MAX_NESTING`].
    fn enter(&mut self) -> Result<(), PdeTextError> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(PdeTextError::at(
                self.pos(),
                format!(
                    "nested more than {MAX_NESTING} levels deep (parentheses, function calls, \
                     signs, powers or for statements)"
                ),
            ));
        }
        Ok(())
    }

    fn is_ident(&self, name: &str) -> bool {
        matches!(&self.peek().tok, Tok::Ident(s) if s == name)
    }

    fn statement(&mut self) -> Result<Stmt, PdeTextError> {
        self.enter()?;
        let s = self.statement_inner();
        self.depth -= 1;
        s
    }

    fn statement_inner(&mut self) -> Result<Stmt, PdeTextError> {
        let (kw, pos) = self.ident(
            "a statement (pde, param, let, unknown, equation, add, boundary, eliminate, include, for)",
        )?;
        match kw.as_str() {
            "pde" => {
                let (name, _) = self.ident("the PDE's name after 'pde'")?;
                Ok(Stmt::Pde(name, pos))
            }
            "param" => {
                let (name, _) = self.ident("a parameter name after 'param'")?;
                self.expect_op("=", "after the parameter name")?;
                Ok(Stmt::Param(name, self.expr()?, pos))
            }
            "let" => {
                let (name, _) = self.ident("a name after 'let'")?;
                let mut args = Vec::new();
                if self.eat_op("(") {
                    loop {
                        args.push(self.ident("an argument name")?.0);
                        if self.eat_op(")") {
                            break;
                        }
                        self.expect_op(",", "between arguments")?;
                    }
                }
                self.expect_op("=", "after the name being defined")?;
                Ok(Stmt::Let(name, args, self.expr()?, pos))
            }
            "unknown" => {
                let (name, _) = self.ident("the unknown's name after 'unknown'")?;
                let mut moment = None;
                if self.eat_op("=") {
                    let (l, lpos) = self.ident("L(l, m) after '='")?;
                    if l != "L" {
                        return Err(PdeTextError::at(
                            lpos,
                            format!("an unknown can only stand for a radiance moment L(l, m), not '{l}'"),
                        ));
                    }
                    self.expect_op("(", "after L")?;
                    let a = self.expr()?;
                    self.expect_op(",", "between l and m")?;
                    let b = self.expr()?;
                    self.expect_op(")", "after m")?;
                    moment = Some((a, b));
                }
                let mut at = None;
                if self.is_ident("at") {
                    self.i += 1;
                    self.expect_op("(", "after 'at' (a shift such as (0, 0, 1))")?;
                    let x = self.expr()?;
                    self.expect_op(",", "between shifts")?;
                    let y = self.expr()?;
                    self.expect_op(",", "between shifts")?;
                    let z = self.expr()?;
                    self.expect_op(")", "after the z shift")?;
                    at = Some([x, y, z]);
                }
                Ok(Stmt::Unknown {
                    name,
                    moment,
                    at,
                    pos,
                })
            }
            "equation" => {
                let target = self.target()?;
                self.expect_op(":", "after the unknown the equation is located at")?;
                let lhs = self.expr()?;
                self.expect_op("=", "between the two sides of the equation")?;
                let rhs = self.expr()?;
                Ok(Stmt::Equation(target, lhs, rhs, pos))
            }
            "add" => {
                let target = self.target()?;
                self.expect_op(":", "after the unknown whose equation gets the term")?;
                Ok(Stmt::AddTerm(target, self.expr()?, pos))
            }
            "boundary" => {
                let kind = self.ident("the boundary kind after 'boundary' (marshak)")?;
                let target = self.target()?;
                self.expect_op(
                    ":",
                    "after the unknown the boundary condition is stated for",
                )?;
                let lhs = self.expr()?;
                self.expect_op("=", "between the two sides of the boundary condition")?;
                let rhs = self.expr()?;
                Ok(Stmt::Boundary {
                    kind,
                    target,
                    lhs,
                    rhs,
                    pos,
                })
            }
            "eliminate" => Ok(Stmt::Eliminate(self.target()?, pos)),
            "include" => {
                let (what, wpos) = self.ident("pn(N) after 'include'")?;
                if what != "pn" {
                    return Err(PdeTextError::at(
                        wpos,
                        format!("only the derived P_N system can be included (include pn(N)), not '{what}'"),
                    ));
                }
                self.expect_op("(", "after pn")?;
                let n = self.expr()?;
                self.expect_op(")", "after the order")?;
                Ok(Stmt::IncludePn(n, pos))
            }
            "for" => {
                let mut ranges = Vec::new();
                loop {
                    let (v, _) = self.ident("a loop variable after 'for'")?;
                    self.expect_op("=", "after the loop variable")?;
                    let lo = self.expr()?;
                    self.expect_op("..", "between the bounds of the range")?;
                    let hi = self.expr()?;
                    ranges.push((v, lo, hi));
                    if !self.eat_op(",") {
                        break;
                    }
                }
                self.expect_op(":", "after the loop ranges")?;
                let body = self.statement()?;
                if matches!(body, Stmt::Pde(..) | Stmt::Param(..) | Stmt::Let(..)) {
                    return Err(PdeTextError::at(
                        pos,
                        "a loop body must be unknown, equation, add, boundary, eliminate or for",
                    ));
                }
                Ok(Stmt::For(ranges, Box::new(body), pos))
            }
            other => Err(PdeTextError::at(
                pos,
                format!(
                    "unknown statement '{other}' (expected one of {})",
                    KEYWORDS.join(", ")
                ),
            )),
        }
    }

    fn target(&mut self) -> Result<Target, PdeTextError> {
        let (name, pos) = self.ident("an unknown's name or L(l, m)")?;
        if name == "L" && self.is_op("(") {
            self.i += 1;
            let l = self.expr()?;
            self.expect_op(",", "between l and m")?;
            let m = self.expr()?;
            self.expect_op(")", "after m")?;
            return Ok(Target::Moment(l, m, pos));
        }
        Ok(Target::Name(name, pos))
    }

    /// expr := term (('+' | '-') term)*
    fn expr(&mut self) -> Result<Ast, PdeTextError> {
        self.chain(Self::term, |op| match op {
            "+" => Some(BinOp::Add),
            "-" => Some(BinOp::Sub),
            _ => None,
        })
    }

    /// term := unary (('*' | '/') unary)*
    fn term(&mut self) -> Result<Ast, PdeTextError> {
        self.chain(Self::unary, |op| match op {
            "*" => Some(BinOp::Mul),
            "/" => Some(BinOp::Div),
            _ => None,
        })
    }

    /// `operand (op operand)*` as one [`Ast::Chain`] (a lone operand as itself).
    fn chain(
        &mut self,
        operand: fn(&mut Self) -> Result<Ast, PdeTextError>,
        op_of: fn(&str) -> Option<BinOp>,
    ) -> Result<Ast, PdeTextError> {
        let first = operand(self)?;
        let mut rest = Vec::new();
        loop {
            let pos = self.pos();
            let op = match self.peek().tok {
                Tok::Op(o) => op_of(o),
                _ => None,
            };
            let Some(op) = op else {
                return Ok(if rest.is_empty() {
                    first
                } else {
                    Ast::Chain(Box::new(first), rest)
                });
            };
            self.i += 1;
            rest.push((op, operand(self)?, pos));
        }
    }

    /// unary := '-' unary | power   (each sign, like each '(' and call, is one nesting level)
    fn unary(&mut self) -> Result<Ast, PdeTextError> {
        self.enter()?;
        let a = self.unary_inner();
        self.depth -= 1;
        a
    }

    fn unary_inner(&mut self) -> Result<Ast, PdeTextError> {
        let pos = self.pos();
        if self.eat_op("-") {
            return Ok(Ast::Neg(Box::new(self.unary()?), pos));
        }
        if self.eat_op("+") {
            return self.unary();
        }
        self.power()
    }

    /// power := atom ('^' unary)?   (right-associative; `-x^2` is `-(x^2)`)
    fn power(&mut self) -> Result<Ast, PdeTextError> {
        let base = self.atom()?;
        let pos = self.pos();
        if self.eat_op("^") {
            let e = self.unary()?;
            return Ok(Ast::Bin(BinOp::Pow, Box::new(base), Box::new(e), pos));
        }
        Ok(base)
    }

    fn atom(&mut self) -> Result<Ast, PdeTextError> {
        let t = self.peek().clone();
        match t.tok {
            Tok::Number(s) => {
                self.i += 1;
                Ok(Ast::Num(s, t.pos))
            }
            Tok::Op("(") => {
                self.i += 1;
                let e = self.expr()?;
                self.expect_op(")", "to close '('")?;
                Ok(e)
            }
            Tok::Ident(name) => {
                self.i += 1;
                if !self.eat_op("(") {
                    return Ok(Ast::Ident(name, t.pos));
                }
                if name == "sum" {
                    let (var, _) = self.ident("the summation index, as in sum(k = 0..N, ...)")?;
                    self.expect_op("=", "after the summation index")?;
                    let lo = self.expr()?;
                    self.expect_op("..", "between the bounds of the sum")?;
                    let hi = self.expr()?;
                    self.expect_op(",", "after the range of the sum")?;
                    let body = self.expr()?;
                    self.expect_op(")", "to close sum(")?;
                    return Ok(Ast::Sum {
                        var,
                        lo: Box::new(lo),
                        hi: Box::new(hi),
                        body: Box::new(body),
                        pos: t.pos,
                    });
                }
                let mut args = Vec::new();
                if !self.eat_op(")") {
                    loop {
                        args.push(self.expr()?);
                        if self.eat_op(")") {
                            break;
                        }
                        self.expect_op(",", "between arguments")?;
                    }
                }
                Ok(Ast::Call(name, args, t.pos))
            }
            other => Err(PdeTextError::at(
                t.pos,
                format!("expected an expression, found {}", Self::describe(&other)),
            )),
        }
    }
}
