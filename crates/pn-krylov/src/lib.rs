//! `pn-krylov` — Krylov methods for `A x = b`, generic over the operator.
//!
//! Nothing here knows of P_N, stencils or scenes: a method sees a [`LinearOperator`] (and a
//! [`Preconditioner`]), a right-hand side and the [`Stopping`] rules, and returns the
//! solution with its [`SolveStats`]. It never prints; a caller watches a solve through the
//! [`IterationObserver`] of the stopping rules.
//!
//! * [`operator`]: the operator and preconditioner traits, [`operator::Identity`],
//!   [`operator::Jacobi`], [`operator::Counted`] and CSR matrices ([`operator::AssembledOperator`]).
//! * [`linalg`]: the parallel vector kernels and the compact CSR product.
//! * Square systems, one file each: [`cg`], [`bicgstab`], [`gmres`]; [`krylov`] picks one by
//!   name ([`KrylovMethod`]).
//! * Least squares on an operator with a transpose: [`cgls`], [`lsqr`], [`lsmr`].
//! * [`control`]: the one stopping controller of every method.
//! * Re-exported here: [`LinearOperator`], [`Preconditioner`], [`KrylovMethod`], the stopping
//!   rules [`Stopping`] (with their [`IterationObserver`]), and what a solve reports
//!   ([`SolveStats`], [`SolveStatus`]; from the private `stats` module).
//!
//! **Tolerance.** Every method stops on the *relative* residual `‖b − A x‖₂ / ‖b‖₂ ≤ tol`;
//! the final residual in [`SolveStats`] is recomputed from the returned solution.
//!
//! Conjugate gradients on a small symmetric positive definite system:
//!
//! ```
//! use pn_krylov::{cg::cg, control::Control, operator::Identity, Stopping};
//!
//! // A = tridiag(-1, 4, -1) as a CSR matrix (sprs), b = 1.
//! let n = 50;
//! let mut t = sprs::TriMat::new((n, n));
//! for i in 0..n {
//!     t.add_triplet(i, i, 4.0);
//!     if i > 0 {
//!         t.add_triplet(i, i - 1, -1.0);
//!         t.add_triplet(i - 1, i, -1.0);
//!     }
//! }
//! let a: sprs::CsMat<f64> = t.to_csr();
//! let b = vec![1.0; n];
//! let mut x = vec![0.0; n];
//! let stopping = Stopping { tol: 1e-12, ..Default::default() };
//! let mut ctl = Control::for_options(&stopping, pn_krylov::linalg::norm(&b));
//! let outcome = cg(&a, &Identity, &b, &mut x, &mut ctl);
//! assert_eq!(outcome, pn_krylov::control::Outcome::Reached);
//! ```
#![warn(missing_docs)]

pub mod bicgstab;
pub mod cg;
pub mod cgls;
pub mod control;
pub mod gmres;
pub mod krylov;
pub mod linalg;
pub mod lsmr;
pub mod lsqr;
pub mod operator;
mod stats;

pub use krylov::KrylovMethod;
pub use operator::{LinearOperator, Preconditioner};
pub use stats::{IterationObserver, SolveStats, SolveStatus, Stopping};
