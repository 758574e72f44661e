//! `pn-drivers` — the work behind each `pn` subcommand, as a library that the command line
//! and the tests call: solve a scene, render, converge, error estimate, bench, trade-off,
//! figure, the derivation printers, reports and plots.

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
