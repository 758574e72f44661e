//! `pnsolver` — the `pn` command-line tool and the compiled stencils.

pub mod cli;

/// Stencils generated at build time by `build.rs` for the orders in `PN_ORDERS`.
pub mod compiled {
    include!(concat!(env!("OUT_DIR"), "/stencils.rs"));
}
