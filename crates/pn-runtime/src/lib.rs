//! `pn-runtime` — from a scene to a solved system, numerics only.
//!
//! It builds on the stencil IR of `pn-stencil` alone: a stencil (compiled by `pn-kernels` or
//! interpreted) comes in as a `&dyn StencilKernel`; neither the computer-algebra system nor
//! the generator is a dependency.
//!
//! * Problem description: [`field`], [`problem`] (including [`problem::sigma_tr`]),
//!   [`scenes`] (built-in; [`scenes::vacuum`]: `slab` and `milne`); [`scene_registry`] lists every built-in scene of `pn solve` and `pn render`.
//! * Discrete system: [`layout`] (unknowns and boundary closure), [`marshak`] (the Marshak
//!   vacuum faces' rows), [`robin`] (a PDE's own boundary conditions on those faces, by
//!   ghost elimination), [`context`] (fields at
//!   staggered positions), [`assemble`] (sprs CSR), [`assemble_split`] (straight into the
//!   parity blocks), [`matfree`] (the matrix-free operator).
//! * Solving: [`operator`] (operator and preconditioner traits), [`linalg`], [`solver`] (one
//!   file per Krylov method, one stopping controller, the parity solvers and multigrid),
//!   [`pipeline`] (the whole chain, [`pipeline::solve_problem`]), [`fld`] (flux-limited
//!   diffusion),
//!   [`convergence`] (resolution studies).
//! * Results: [`unstagger`], [`energy`], [`memory`], [`bandwidth`] (the
//!   machine's measured memory bandwidth, for the roofline of `pn bench`) and
//!   [`memory_estimate`]; [`threads`] for `--threads`.
//! * [`reference`]: analytic and semi-analytic reference solutions (point source, the 1D
//!   P_N–Marshak slab and Milne problems, StaRMAP files).
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

pub mod fld;
pub mod reference;

pub mod assemble;
pub mod assemble_split;
pub mod bandwidth;
pub mod context;
pub mod convergence;
pub mod cpu;
pub mod energy;
pub mod field;
pub mod layout;
pub mod marshak;
pub mod matfree;
pub mod memory;
pub mod memory_estimate;
pub mod pipeline;
pub mod problem;
pub mod robin;
pub mod scene_registry;
pub mod scenes;
pub mod solver;
pub mod threads;
pub mod unstagger;
