//! `pn-drivers` — the user commands of `pn`, as a library that the command line and the
//! tests call: solve a scene ([`solve`], with [`fld_method`], [`pointsource_extras`] and
//! [`vacuum_extras`]), render ([`render`]), converge ([`converge`]), the error estimate
//! ([`error_estimate`]), compare two images ([`compare`]), the Mitsuba export
//! ([`export_mitsuba`], with [`mitsuba`]: writing an export and running Mitsuba, also for the
//! lab and the tests), the derivation printers ([`derive_cmds`], [`stencil`]) and the
//! text-PDE files ([`pde_text`]).
//!
//! The experiments (`pn race`, `pn bench`, `pn tradeoff`, `pn figure`) are in `pn-lab`,
//! which builds on this crate ([`scene_setup`], [`fld_setup`], [`render`]); dependencies run
//! lab → drivers → libraries, never the reverse.
//!
//! Every driver takes plain option values (a `…Request` struct with public fields and a
//! `Default`) and a `std::io::Write` for what the command prints; nothing here parses a
//! command line or reads the environment (the `pn` binary does both and passes, for
//! example, the solver tuning of `PN_MG_*` in [`scene_setup::SolveRequest::tuning`]).
//!
//! Module dependencies run one way: [`scene_setup`] (the options of a solve, the scene and
//! the stencil they select) is below [`fld_setup`], [`error_estimate`] and
//! [`pointsource_extras`], which are below [`solve`], [`fld_method`] and [`converge`];
//! [`render`] uses [`fld_setup`].
//!
//! # Example
//!
//! Solve the checkerboard at P_1 on a 14×14 grid, with the library alone:
//!
//! ```
//! use pn_drivers::solve::{run, SolveRequest};
//!
//! let out = std::env::temp_dir().join(format!("pn-drivers-doc-{}", std::process::id()));
//! let request = SolveRequest {
//!     scene: "checkerboard".into(),
//!     order: Some(1),
//!     res: Some(vec![14]),
//!     out: Some(out.clone()),
//!     threads: Some(1),
//!     ..Default::default()
//! };
//! let mut printed = Vec::new();
//! run(&request, &mut printed)?;
//! assert!(String::from_utf8(printed)?.starts_with("checkerboard P_1 2D 14×14"));
//! let report: serde_json::Value =
//!     serde_json::from_str(&std::fs::read_to_string(out.join("report.json"))?)?;
//! assert_eq!(report["converged"], true);
//! std::fs::remove_dir_all(&out)?;
//! # Ok::<(), anyhow::Error>(())
//! ```

#![warn(missing_docs)]

pub mod compare;
pub mod converge;
pub mod derive_cmds;
pub mod error_estimate;
pub mod export_mitsuba;
pub mod fld_method;
pub mod fld_setup;
pub mod mitsuba;
pub mod pde_text;
pub mod pointsource_extras;
pub mod progress;
pub mod render;
pub mod scene_setup;
pub mod solve;
pub mod solve_distributed;
pub mod stencil;
pub mod vacuum_extras;

/// The README's code blocks, compiled and run as doc tests (its Rust example uses the crates
/// as a user would).
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
struct ReadmeDoctests;
