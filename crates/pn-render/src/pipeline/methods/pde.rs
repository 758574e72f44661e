//! A text PDE (docs/pde-text.md): its 3D stencil solved like CDA, the first-scatter source up
//! to the highest band the PDE reads, its auxiliary unknowns hidden from the renderer.

use super::grid::{solve_on_grid, stencil_solve, GridMethod};
use super::{MsSolution, MultipleScattering, PreparedScene};
use crate::pde_kernel::PdeKernel;
use anyhow::Result;
use std::sync::Arc;

/// A text PDE's system.
pub struct TextPde {
    pde: Arc<PdeKernel>,
    /// `pde:NAME`.
    name: String,
}

impl TextPde {
    /// The method of `pde`.
    pub fn new(pde: Arc<PdeKernel>) -> Self {
        let name = format!("pde:{}", pde.name);
        Self { pde, name }
    }
}

impl MultipleScattering for TextPde {
    fn name(&self) -> &str {
        &self.name
    }

    fn solve(&self, p: &PreparedScene<'_>) -> Result<MsSolution> {
        let pde = &self.pde;
        let method = GridMethod {
            kernel: Some(&pde.choice),
            // The first-scatter source's bands: a text PDE reads Q_l^m up to the highest
            // band it references (filtered P_N: N; SP_N and CDA: 0).
            max_band: pde.source_band,
            solve_band: pde.source_band,
            uses_sigma_t_min: true,
            correction: None,
        };
        solve_on_grid(p, &method, &|problem, notes| {
            let mut run = stencil_solve(p, &pde.choice, problem, notes)?;
            // Auxiliary unknowns (SP_3's φ_2) are not radiance moments: the renderer must
            // not read them as spherical-harmonic coefficients.
            pde.zero_auxiliary(&mut run.moments);
            Ok(run)
        })
    }
}
