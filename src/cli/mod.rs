//! Subcommands of the `pn` binary, one module each.

pub mod bench;
pub mod converge;
pub mod derive_cmds;
pub mod error_estimate;
pub mod fld_method;
pub mod pointsource_extras;
pub mod solve;
pub mod stencil;
