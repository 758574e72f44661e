//! The point-source profile (docs/pointsource.md): the discrete solution along a ray from the
//! source beside the semi-analytic P_N solution, CDA and Grosjean (the plot a reader of the
//! paper knows as its Figure 9; `pn_formats::plot::profile` writes it as CSV and PNG).

use super::closed_forms::{cda_point_source, grosjean};
use super::pointsource::PointSourceModes;

/// One sample of the profile: normalised fluences `4πφ/σ_t²` at optical distance `tau`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileRow {
    /// Optical distance τ = σ_t r from the source.
    pub tau: f64,
    /// The discrete (solved) value.
    pub solved: f64,
    /// The semi-analytic P_N value ([`crate::reference::PointSourceModes`]).
    pub pn_exact: f64,
    /// Classical diffusion ([`crate::reference::cda_point_source`]).
    pub cda: f64,
    /// Grosjean's approximation of transport ([`crate::reference::grosjean`]).
    pub grosjean: f64,
}

impl ProfileRow {
    /// A row for a point source at optical distance `tau`: the discrete value `solved` beside
    /// the semi-analytic `modes` (smooth part), CDA and Grosjean for the same medium
    /// (Grosjean is for isotropic scattering: it uses the albedo and ignores g).
    pub fn point_source(tau: f64, solved: f64, modes: &PointSourceModes) -> Self {
        Self {
            tau,
            solved,
            pn_exact: modes.fluence(tau),
            cda: cda_point_source(tau, modes.albedo, modes.g),
            grosjean: grosjean(tau, modes.albedo),
        }
    }
}
