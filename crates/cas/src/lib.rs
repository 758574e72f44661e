//! `cas` — a small computer-algebra system for deriving the P_N equations.
//!
//! * [`number`]: exact numbers, rationals times square roots of rationals (surds).
//! * [`expr`]: the expression tree ([`Expr`]) and its constructors.
//! * [`index`]: integer index arithmetic (linear forms) and sign assumptions.
//! * [`passes`]: rewrite passes, one per module.
//! * [`print`](mod@print): LaTeX and Rust printers.
//!
//! # Tutorial
//!
//! Build an expression, rewrite it with passes, print it:
//!
//! ```
//! use cas::{Expr, DirVar, ShKind, Axis};
//! use cas::passes::{normalize, sh_convert, sh_recursion, orthonormality, collect};
//! use cas::index::Assumptions;
//!
//! // ∫ Y_{1,0}(ω) ω_z Y_{0,0}(ω) dω in the real basis
//! let y = |l, m| Expr::sh(ShKind::Real, Expr::Int(l), Expr::Int(m), DirVar::Omega);
//! let e = Expr::integral(DirVar::Omega,
//!     Expr::Mul(vec![y(1, 0), Expr::DirComp(DirVar::Omega, Axis::Z), y(0, 0)]));
//! // Go to the complex basis for the Y_{0,0} factor, apply the ω_z recursion, come back.
//! let none = Assumptions::none();
//! let e = normalize(&sh_convert::real_to_complex(&e, &none));
//! let e = normalize(&sh_recursion::define_coefficients(&sh_recursion::apply_recursion(&e)));
//! let e = normalize(&sh_convert::complex_to_real(&e, &none));
//! let e = collect::collect(&orthonormality::orthonormality(&e));
//! // = a_{0,0} = 1/√3
//! assert!((e.as_number().unwrap().to_f64() - 1.0 / 3f64.sqrt()).abs() < 1e-15);
//! assert_eq!(cas::print::latex::latex(&e), r"\frac{\sqrt{3}}{3}");
//! ```
#![warn(missing_docs)]

pub mod expr;
pub mod index;
pub mod number;
pub mod passes;
pub mod print;

pub use expr::{Axis, DirVar, Expr, FieldName, ShKind};
pub use number::Surd;
