//! `pn-codegen` — from the radiative transfer equation to stencil code.
//!
//! * [`derive`]: the real P_N equations derived with the `cas` crate.
//! * [`stencil`]: the stencil IR (canonical discretized form) and the [`stencil::StencilKernel`]
//!   trait that both interpreted and generated stencils implement.

pub mod derive;
pub mod stencil;
