//! Boundary conditions that a PDE states for itself: linear (Robin-type) relations between
//! the values of cell-centred unknowns on a domain face and their outward normal
//! derivatives (docs/pde-text.md, "Boundary conditions").
//!
//! A [`RobinBoundary`] holds K conditions, one per unknown it closes (its *targets*):
//!
//! ```text
//!     Σ_j A_ij u_j + Σ_k B_ik ∂_n u_k = 0        (i = 1..K, on the face; ∂_n = n·∇, n outward)
//! ```
//!
//! with `j` over any unknowns centred along the face normal and `k` over the targets. The
//! coefficients are [`Weight`]s whose fields are read at the face point (offset 0 from
//! it). SP_N's Marshak conditions (`pdes/sp3.pde`) and the Robin condition of diffusion
//! (`pdes/cda.pde`, `pdes/sp1.pde`) have this form. The runtime (`pn_runtime::RobinFaces`)
//! closes a stencil with them by eliminating the ghost values its rows reach for across the
//! face; a kernel carries them through [`StencilKernel::boundary_conditions`], so every
//! assembly path sees them. [`WithBoundary`] attaches them to any kernel.

use crate::ir::{Dim, FieldContext, MomentPlacement, StencilKernel, TermPattern};
pub use crate::ir::{RobinBoundary, RobinCondition};
use std::sync::Arc;

/// A kernel with boundary conditions attached: every [`StencilKernel`] method is the inner
/// kernel's, and [`StencilKernel::boundary_conditions`] returns the conditions.
#[derive(Clone)]
pub struct WithBoundary {
    /// The stencil.
    pub inner: Arc<dyn StencilKernel>,
    /// Its boundary conditions.
    pub boundary: RobinBoundary,
}

impl StencilKernel for WithBoundary {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn dim(&self) -> Dim {
        self.inner.dim()
    }
    fn moments(&self) -> &[MomentPlacement] {
        self.inner.moments()
    }
    fn pattern(&self, row: usize) -> &[TermPattern] {
        self.inner.pattern(row)
    }
    fn eval_row(&self, row: usize, ctx: &dyn FieldContext, weights: &mut [f64]) -> f64 {
        self.inner.eval_row(row, ctx, weights)
    }
    fn boundary_conditions(&self) -> Option<&RobinBoundary> {
        Some(&self.boundary)
    }
}
