//! `pn-codegen` — from the radiative transfer equation to stencil code.
//!
//! * [`derive`](mod@derive): the real P_N equations derived with the `cas` crate.
//! * [`pde`], [`placement`], [`discretize`]: input PDE systems (P_N, its 2D reduction, CDA),
//!   staggered placement and the offset-stack discretizer producing the stencil IR of the
//!   `pn-stencil` crate.
//! * [`text`]: linear PDE systems written as text (`pn solve --pde FILE`), parsed into
//!   the same [`pde::PdeSystem`] form.
//! * [`codegen`]: Rust code generation, with the [`codegen::Builder`] that the `pn-kernels`
//!   build script calls (like `prost-build`: the generated code depends only on
//!   `pn-stencil`).
//!
//! The independent check of the derivation (sphere quadrature, real spherical harmonics) is
//! `pn_stencil::quadrature` (docs/design.md §2.3).
//!
//! # Example
//!
//! Derive the real P_1 equations, place and discretize them on a staggered 3D grid, and
//! generate the Rust source of the stencil:
//!
//! ```
//! use pn_codegen::codegen::generate_source;
//! use pn_codegen::derive::real_pn_system;
//! use pn_codegen::discretize::pn_ir;
//! use pn_stencil::{Dim, Staggering};
//!
//! // (N+1)² = 4 moments, one equation each.
//! let sys = real_pn_system(1).unwrap();
//! assert_eq!(sys.equations.len(), 4);
//!
//! // One stencil row per moment; L_0^0 at the cell centre, the three l = 1 moments each
//! // half a cell off along one axis (on the faces).
//! let ir = pn_ir(&sys, Dim::Three, Staggering::Staggered).unwrap();
//! assert_eq!(ir.name, "p1_3d_staggered");
//! assert_eq!(ir.rows.len(), 4);
//! assert_eq!(ir.moments[0].shift, [0, 0, 0]);
//! for m in ir.moments.iter().filter(|m| m.l == 1) {
//!     assert_eq!(m.shift.iter().sum::<u8>(), 1);
//! }
//!
//! // The generated module, as build.rs of pn-kernels writes it.
//! let src = generate_source(&[ir]).unwrap();
//! assert!(src.contains("pub mod p1_3d_staggered"));
//! ```
#![warn(missing_docs)]

pub mod codegen;
pub mod derive;
pub mod discretize;
pub mod pde;
pub mod placement;
pub mod text;
