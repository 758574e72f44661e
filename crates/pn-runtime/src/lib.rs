//! `pn-runtime` — from a scene to a solved system.
//!
//! * [`reference`]: analytic and semi-analytic reference solutions (point source).
//! * [`fld`]: flux-limited diffusion (nonlinear Gauss–Seidel solver and limiters).
//! * Problem description: [`field`], [`problem`], [`scenes`] (built-in), [`scene_file`]
//!   (TOML), [`vol`] and [`npy`] (voxel data and array files); [`scene_registry`] lists
//!   every built-in scene of `pn solve` and `pn render`.
//! * Discrete system: [`layout`] (unknowns and boundary closure), [`context`] (fields at
//!   staggered positions), [`assemble`] (sprs CSR).
//! * Solving: [`linalg`], [`solver`] (CGNR), [`pipeline`] (the whole chain).
//! * Results: [`unstagger`], [`energy`], [`output`], [`memory`]; [`threads`] for `--threads`.

pub mod fld;
pub mod reference;

pub mod assemble;
pub mod assemble_split;
pub mod context;
pub mod convergence;
pub mod energy;
pub mod field;
pub mod layout;
pub mod linalg;
pub mod matfree;
pub mod memory;
pub mod memory_estimate;
pub mod npy;
pub mod operator;
pub mod output;
pub mod pipeline;
pub mod plot;
pub mod problem;
pub mod render;
pub mod scene_file;
pub mod scene_registry;
pub mod scenes;
pub mod solver;
pub mod threads;
pub mod unstagger;
pub mod vol;
