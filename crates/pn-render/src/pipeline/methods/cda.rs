//! CDA: classical diffusion, the fluence on the staggered grid, the first-scatter source's
//! band 0.

use super::grid::{solve_on_grid, stencil_correction, stencil_solve, GridMethod};
use super::{MsSolution, MultipleScattering, PreparedScene};
use anyhow::Result;
use pn_kernels::{cda_kernel, Dim};

/// Classical diffusion.
pub struct Cda {
    /// The scattering order the sweeps carry ([`crate::SolveSettings::sweep_band`]; 0: the
    /// diffusion's own, above that delta-M's order and the first-scatter source's highest
    /// band, with the diffusion as the sweeps' correction).
    pub sweep_band: usize,
}

impl MultipleScattering for Cda {
    fn name(&self) -> &str {
        "cda"
    }

    fn delta_m_order(&self) -> Option<u32> {
        Some(self.sweep_band.max(1) as u32)
    }

    fn solve(&self, p: &PreparedScene<'_>) -> Result<MsSolution> {
        let kernel = cda_kernel(Dim::Three)?;
        let correct = |problem: &_, notes: &mut _| stencil_correction(p, &kernel, problem, notes);
        let method = GridMethod {
            kernel: Some(&kernel),
            max_band: self.sweep_band as u32,
            solve_band: 0,
            uses_sigma_t_min: true,
            correction: Some(&correct),
        };
        solve_on_grid(p, &method, &|problem, notes| {
            stencil_solve(p, &kernel, problem, notes)
        })
    }
}
