//! `pnsolver` — the `pn` command-line tool and the compiled stencils.

pub mod cli;
pub mod stencils;

/// Stencils generated at build time by `build.rs` for the orders in `PN_ORDERS` (default
/// 1–5; 2D and 3D, staggered and collocated) plus CDA and diffusion (D as a field): one
/// module per stencil (e.g. `p3_3d_staggered::Kernel`), `KERNELS` and `find(name)`.
/// Use [`stencils`] to get a stencil with the interpreted fallback.
pub mod compiled {
    include!(concat!(env!("OUT_DIR"), "/stencils.rs"));
}
