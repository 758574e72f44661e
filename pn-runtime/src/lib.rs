//! `pn-runtime` — from a scene to a solved system.
//!
//! * [`reference`]: analytic and semi-analytic reference solutions (point source).
//! * [`fld`]: flux-limited diffusion (nonlinear Gauss–Seidel solver and limiters).

pub mod fld;
pub mod reference;
