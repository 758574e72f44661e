//! CDA: classical diffusion, the fluence on the staggered grid, the first-scatter source's
//! band 0.

use super::grid::{solve_on_grid, stencil_correction, stencil_solve, GridMethod};
use super::{MsSolution, MultipleScattering, PreparedScene};
use anyhow::Result;
use pn_kernels::{cda_kernel, Dim};

/// Classical diffusion.
pub struct Cda;

impl MultipleScattering for Cda {
    fn name(&self) -> &str {
        "cda"
    }

    fn delta_m_order(&self) -> Option<u32> {
        Some(1)
    }

    fn solve(&self, p: &PreparedScene<'_>) -> Result<MsSolution> {
        let kernel = cda_kernel(Dim::Three)?;
        let correct = |problem: &_, notes: &mut _| stencil_correction(p, &kernel, problem, notes);
        let method = GridMethod {
            kernel: Some(&kernel),
            max_band: 0,
            uses_sigma_t_min: true,
            correction: Some(&correct),
        };
        solve_on_grid(p, &method, &|problem, notes| {
            stencil_solve(p, &kernel, problem, notes)
        })
    }
}
