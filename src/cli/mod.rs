//! Subcommands of the `pn` binary, one module each.

pub mod bench;
pub mod bench_model;
pub mod compare;
pub mod converge;
pub mod derive_cmds;
pub mod error_estimate;
pub mod export_mitsuba;
pub mod figure;
pub mod fld_method;
pub mod pointsource_extras;
pub mod render;
pub mod solve;
pub mod stencil;
pub mod tradeoff;
