//! P_N: the real spherical-harmonic moments up to order N on the staggered grid, the
//! first-scatter source up to band N.

use super::grid::{solve_on_grid, stencil_correction, stencil_solve, GridMethod};
use super::{MsSolution, MultipleScattering, PreparedScene};
use anyhow::Result;
use pn_kernels::{pn_kernel, Dim, Staggering};

/// The P_N method of order `order`.
pub struct Pn {
    /// The order N.
    pub order: usize,
    /// The scattering order the sweeps carry (≥ N; [`crate::SolveSettings::sweep_band`]):
    /// delta-M's order and the first-scatter source's highest band.
    pub sweep_band: usize,
}

impl MultipleScattering for Pn {
    fn name(&self) -> &str {
        "pn"
    }

    fn order(&self) -> Option<usize> {
        Some(self.order)
    }

    fn delta_m_order(&self) -> Option<u32> {
        Some(self.sweep_band.max(self.order) as u32)
    }

    fn solve(&self, p: &PreparedScene<'_>) -> Result<MsSolution> {
        let kernel = pn_kernel(self.order, Dim::Three, Staggering::Staggered)?;
        let correct = |problem: &_, notes: &mut _| stencil_correction(p, &kernel, problem, notes);
        let method = GridMethod {
            kernel: Some(&kernel),
            max_band: self.sweep_band.max(self.order) as u32,
            solve_band: self.order as u32,
            uses_sigma_t_min: true,
            correction: Some(&correct),
        };
        solve_on_grid(p, &method, &|problem, notes| {
            stencil_solve(p, &kernel, problem, notes)
        })
    }
}
