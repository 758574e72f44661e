//! `cas` — a small computer-algebra system for deriving the P_N equations.
//!
//! * [`number`]: exact numbers, rationals times square roots of rationals (surds).
//! * [`expr`]: the expression tree ([`Expr`]) and its constructors.
//!
//! Rewrite passes, printers and the tutorial live in modules added beside these.

pub mod expr;
pub mod number;

pub use expr::{Axis, DirVar, Expr, FieldName, ShKind};
pub use number::Surd;
