//! `pn-codegen` — from the radiative transfer equation to stencil code.
//!
//! * [`derive`](mod@derive): the real P_N equations derived with the `cas` crate.
//! * [`pde`], [`placement`], [`discretize`]: input PDE systems (P_N, its 2D reduction, CDA),
//!   staggered placement and the offset-stack discretizer producing the stencil IR of the
//!   `pn-stencil` crate.
//! * [`codegen`]: Rust code generation, with the [`codegen::Builder`] that the `pn-kernels`
//!   build script calls (like `prost-build`: the generated code depends only on
//!   `pn-stencil`).
//!
//! The independent check of the derivation (sphere quadrature, real spherical harmonics) is
//! `pn_stencil::quadrature` (docs/design.md §2.3).

pub mod codegen;
pub mod derive;
pub mod discretize;
pub mod pde;
pub mod placement;
