//! `pn-stencil` — the stencil IR through which discretized PDE systems reach the runtime.
//!
//! The generator (`pn-codegen`) produces a [`StencilIr`] for each P_N order, dimension and
//! grid arrangement ([`Staggering`]); the runtime assembles and applies it through the
//! [`StencilKernel`] trait, which both the generated code (crate `pn-kernels`) and the
//! [`InterpretedKernel`] implement. This crate depends on neither the computer-algebra system
//! nor the generator, so that the numerics build on it alone.
//!
//! * The IR: [`StencilIr`], [`StencilRow`], [`StencilTerm`], [`Weight`], [`FieldRef`],
//!   [`MomentPlacement`] and half-cell coordinates ([`HalfOffset`]); see the `ir` module
//!   documentation below for the coordinate convention (docs/design.md §3).
//! * Evaluation: [`StencilKernel`], [`FieldContext`], [`TermPattern`], [`InterpretedKernel`] (and its former tree walk, [`TreeWalk`]).
//! * [`quadrature`]: Gauss–Legendre and sphere quadrature, real spherical harmonics,
//!   transport matrices and phase-function moments (docs/design.md §2.3).
//! * [`marshak`]: the half-range Gram matrices and the Marshak vacuum closure derived from
//!   them (docs/design.md §3, "Domain and boundary").
//! * [`robin`]: boundary conditions a PDE states for itself (Robin/Marshak-type relations
//!   of face values and normal derivatives, docs/pde-text.md) and [`robin::WithBoundary`].
//!
//! ```
//! use pn_stencil::{quadrature, Dim, Staggering};
//!
//! // (N+1)² moments for P_N; the P_1 transport matrix along x couples L_0^0 and L_1^1.
//! assert_eq!(quadrature::moment_count(1), 4);
//! let [mx, _, _] = quadrature::transport_matrices(1);
//! assert!((mx[0][3] - 1.0 / 3f64.sqrt()).abs() < 1e-12);
//! assert_eq!(Dim::Three.axes(), 3);
//! assert_eq!(Staggering::Staggered.as_str(), "staggered");
//! ```
#![warn(missing_docs)]

mod interpret;
mod ir;
pub mod marshak;
pub mod quadrature;
pub mod robin;

pub use interpret::{InterpretedKernel, TreeWalk};
pub use ir::{
    Dim, FieldContext, FieldRef, HalfOffset, MomentPlacement, RobinBoundary, RobinCondition,
    StencilError, StencilIr, StencilKernel, StencilRow, StencilTerm, TermPattern, Weight,
};

/// Highest P_N order the derivation accepts and the runtime runs (keeps exact arithmetic
/// and run time bounded).
pub const MAX_ORDER: usize = 60;

/// How the unknowns of a stencil are arranged on the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Staggering {
    /// Staggered grids derived from the coupling structure (no interpolation of unknowns;
    /// docs/design.md §3).
    Staggered,
    /// Every unknown at the cell centre (oscillates; for demonstration).
    Collocated,
}

impl Staggering {
    /// `"staggered"` or `"collocated"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Staggering::Staggered => "staggered",
            Staggering::Collocated => "collocated",
        }
    }
}
