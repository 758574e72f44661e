//! `pn-codegen` — from the radiative transfer equation to stencil code.
//!
//! * [`derive`](mod@derive): the real P_N equations derived with the `cas` crate.
//! * [`quadrature`]: sphere quadrature, real spherical harmonics and phase-function moments
//!   (the independent check of the derivation, DESIGN.md §2.3).
//! * [`stencil`]: the stencil IR (canonical discretized form) and the [`stencil::StencilKernel`]
//!   trait that both interpreted and generated stencils implement.
//! * [`pde`], [`placement`], [`discretize`]: input PDE systems (P_N, its 2D reduction, CDA),
//!   staggered placement and the offset-stack discretizer producing the IR.
//! * [`interpret`], [`codegen`]: run-time evaluation of the IR and Rust code generation
//!   (with the [`codegen::Builder`] used by `build.rs`).

pub mod codegen;
pub mod derive;
pub mod discretize;
pub mod interpret;
pub mod pde;
pub mod placement;
pub mod quadrature;
pub mod stencil;
