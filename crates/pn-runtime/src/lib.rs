//! `pn-runtime` — from a scene to a solved system, numerics only.
//!
//! It builds on the stencil IR of `pn-stencil` alone: a stencil (compiled by `pn-kernels` or
//! interpreted) comes in as a `&dyn StencilKernel`; neither the computer-algebra system nor
//! the generator is a dependency.
//!
//! Public modules:
//!
//! * Problem description: [`field`], [`problem`] (including [`problem::sigma_tr`]),
//!   [`scenes`] (built-in; [`scenes::vacuum`]: `slab` and `milne`); [`scene_registry`] lists
//!   every built-in scene of `pn solve` and `pn render`.
//! * Discrete system: [`marshak`] (the Marshak vacuum faces' rows), [`assemble`] (sprs CSR),
//!   [`assemble_split`] (straight into the parity blocks).
//! * Solving: [`solver`] (the solver kinds and options, the parity solvers and multigrid, on
//!   the Krylov methods of `pn-krylov`),
//!   [`pipeline`] (the whole chain, [`pipeline::solve_problem`]), [`fld`] (flux-limited
//!   diffusion), [`convergence`] (resolution studies).
//! * Results and resources: [`memory_estimate`]; [`bandwidth`] (the machine's measured
//!   memory bandwidth, for the roofline of `pn bench`).
//! * [`reference`]: analytic and semi-analytic reference solutions (point source, the 1D
//!   P_N–Marshak slab and Milne problems, StaRMAP files).
//!
//! Re-exported here, from private modules:
//!
//! * [`Layout`]: the unknowns and their boundary closure; [`RowContext`]: fields at staggered
//!   positions, and [`apply_sampling`]; [`RobinFaces`]: a PDE's own boundary conditions on
//!   the vacuum faces, by ghost elimination; [`MatFreeOperator`]: the matrix-free operator.
//! * [`unstagger`] into [`CellMoments`]; [`energy_balance`] ([`EnergyBalance`]);
//!   [`peak_memory_bytes`].
//! * [`with_threads`] and [`effective_threads`] for `--threads`; [`missing_features`]: the
//!   CPU features the build assumes and this machine lacks.
//! * The main entry points again, for short paths: [`Problem`], [`solve_problem`],
//!   [`Solution`].
//!
//! Solving the checkerboard at P_1 on a coarse grid (the stencil comes from `pn-kernels`):
//!
//! ```
//! use pn_kernels::{pn_kernel, Dim, Staggering};
//! use pn_runtime::pipeline::solve_problem;
//! use pn_runtime::scenes::{builtin, BuiltinOptions};
//! use pn_runtime::solver::{SolverKind, SolverOptions};
//!
//! let opts = BuiltinOptions { res: Some(vec![21]), ..Default::default() };
//! let scene = builtin("checkerboard", &opts).unwrap();
//! let p1 = pn_kernel(1, Dim::Two, Staggering::Staggered).unwrap();
//! let solver_opts = SolverOptions { tol: 1e-10, ..Default::default() };
//! let sol = solve_problem(&scene.problem, p1.kernel.as_ref(), SolverKind::ParityCg, &solver_opts)
//!     .unwrap();
//! assert!(sol.stats.converged() && sol.stats.relative_residual <= 1e-10);
//! // What the source emits is absorbed (the Neumann box lets nothing out).
//! let balance = sol.energy.unwrap();
//! assert!(balance.relative_imbalance < 1e-6, "{balance:?}");
//! ```
#![warn(missing_docs)]

pub mod assemble;
pub mod assemble_split;
pub mod bandwidth;
mod context;
pub mod convergence;
mod cpu;
mod energy;
pub mod field;
pub mod fld;
mod layout;
pub mod marshak;
mod matfree;
mod memory;
pub mod memory_estimate;
pub mod phase;
pub mod pipeline;
pub mod problem;
pub mod reference;
mod robin;
pub mod scene_registry;
pub mod scenes;
pub mod solver;
mod threads;
mod unstagger;

pub use context::{apply_sampling, RowContext};
pub use cpu::missing_features;
pub use energy::{energy_balance, EnergyBalance};
pub use layout::Layout;
pub use matfree::MatFreeOperator;
pub use memory::peak_memory_bytes;
pub use pipeline::{solve_problem, Solution};
pub use problem::Problem;
pub use robin::RobinFaces;
pub use threads::{check_threads, effective_threads, max_threads, with_threads};
pub use unstagger::{unstagger, CellMoments};
