//! Flux-limited diffusion (FLD) and classical diffusion (CDA) on a uniform cell-centred grid
//! (Koerner et al. 2014, "Flux-limited diffusion for multiple scattering in participating
//! media").
//!
//! FLD solves the steady diffusion equation `−∇·(D_F ∇φ) + σ_a φ = q` for the fluence φ with
//! the nonlinear coefficient `D_F = F(R)/max(σ_t, σ_ε)`, where `R = |∇φ|/(σ_t φ)` is the
//! Knudsen number and F a flux limiter ([`Limiter`]), both evaluated on the cell faces. CDA
//! is the constant limiter 1/3 and uses the same solver. The nonlinear system is solved by red–black Gauss–Seidel with SOR
//! ([`solve_fld`]), the coefficient being refreshed from the current φ as the sweeps go.
//!
//! * [`limiter`]: the five flux limiters and CDA;
//! * [`grid`]: the grid and the problem (fields, validation, index order);
//! * [`faces`]: the diffusion coefficients on the cell faces, shared by both routes;
//! * [`params`]: solver parameters and their validation;
//! * `operator`: the discretisation (coefficients, residual, sweeps, discrete flux);
//! * [`solver`]: the iteration and the public entry points;
//! * [`picard`]: the same FLD solved by Picard iteration through a generated diffusion
//!   stencil and the project's linear solvers.

pub mod faces;
pub mod grid;
pub mod limiter;
mod operator;
pub mod params;
pub mod picard;
pub mod solver;

pub use faces::FaceCoefficients;
pub use grid::{FldGrid, FldProblem};
pub use limiter::Limiter;
pub use params::FldParams;
pub use picard::{solve_fld_picard, PicardOptions, PicardSolution};
pub use solver::{
    face_diffusion_coefficients, face_flux_ratio, flux_magnitude_ratio, relative_residual,
    solve_fld, solve_fld_from, FaceFluence, FldSolution,
};
