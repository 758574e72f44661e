//! Subcommands of the `pn` binary, one module each.

pub mod derive_cmds;
pub mod solve;
pub mod stencil;
