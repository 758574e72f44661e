//! Resolution studies and Richardson error estimates (docs/convergence.md).
//!
//! * [`restrict`]: cell-centred fields from a fine grid to a nested coarse grid (average of
//!   the children) and block averages (exact overlap weights of cells and blocks).
//! * [`order`]: relative norms, observed orders of convergence from three levels or from two
//!   levels against the finest, and the Richardson estimate of a fine solution's error.
//! * [`study`]: the table of a self-convergence study from solved levels.
//!
//! Conventions: all fields are per-cell arrays in C order of `(nx, ny, nz)` (x slowest) as
//! written to `fluence.npy`; every cell of a grid has the same volume, so discrete L2 norms
//! are plain sums. The error model is `u_h = u + C h^p` (docs/design.md §3 discretization is
//! second order for smooth fields, p = 2).

pub mod order;
pub mod restrict;
pub mod study;

pub use order::{
    l2_diff, observed_order, rel_l2_diff, richardson, solve_order, RichardsonEstimate,
};
pub use restrict::{block_averages, restrict, restriction_ratio};
pub use study::{analyse, check_nesting, coarse_error_factor, Level, StudyRow, StudyTable};
