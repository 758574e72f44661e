//! `pn-lab` — the laboratory: the experiments behind pnsolver's measurements, each a `pn`
//! subcommand whose dated output is kept under `docs/lab/`.
//!
//! * [`race`]: pn against Mitsuba 3 at equal error, in wall time (`pn race`, docs/race.md),
//!   with its ablation study;
//! * [`bench`](mod@bench): the fixed benchmark suite of the solvers, with the roofline, the
//!   2D-against-slab and phase-function models, the text PDEs and compiled against
//!   interpreted stencils (`pn bench`, docs/solvers.md);
//! * [`tradeoff`]: error against time of CDA, FLD and P_N on the point source
//!   (`pn tradeoff`, docs/tradeoff.md);
//! * [`figure`]: one scene rendered with CDA, FLD, P_1, P_3, P_5 (and Mitsuba) side by side
//!   (`pn figure`, docs/rendering.md);
//! * `plot`: the one place the lab registers the plot fonts.
//!
//! Every experiment takes a `…Request` struct with public fields (the `pn` binary fills it
//! from its command line and environment; nothing here reads or sets an environment
//! variable) and a `std::io::Write` for what the command prints; progress goes to stderr.
//! Tables are [`pn_formats::Table`]s, written as CSV and Markdown.
//!
//! Dependencies run one way: lab → `pn-drivers` (the shared setup: `scene_setup`,
//! `fld_setup`, `render`) → the libraries (`pn-runtime`, `pn-kernels`, `pn-codegen`,
//! `pn-stencil`, `pn-formats`); never the reverse. Inside the crate, `bench_rows` is below
//! [`bench`](mod@bench) (and its `bench_model`, `bench_pde`, `bench_roofline` and
//! `bench_kernels` sections) and [`tradeoff`].

#![warn(missing_docs)]

pub mod bench;
mod bench_kernels;
mod bench_model;
mod bench_pde;
mod bench_roofline;
mod bench_rows;
pub mod figure;
mod plot;
pub mod race;
pub mod tradeoff;
