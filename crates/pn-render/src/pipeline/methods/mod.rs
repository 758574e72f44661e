//! The multiple-scattering methods: each is one implementation of [`MultipleScattering`],
//! one file each — [`pn`] (P_N), [`cda`] (classical diffusion), [`fld`] (flux-limited
//! diffusion), [`pop`] (Principal-Ordinates Propagation), [`none`] (single scattering only)
//! and [`pde`] (a text PDE, docs/pde-text.md). [`method_for`] picks the scene's once; the
//! pipeline then only calls the trait. The grid methods (P_N, CDA, FLD, text PDEs) share
//! `grid`: the cropped solve grid, the first-scatter source, the transport sweeps.

use super::report::{SolverReport, UnknownStats};
use super::RenderOptions;
use crate::delta_m::LightLeg;
use crate::light_depth::LightDepth;
use crate::pde_kernel::PdeKernel;
use crate::pop::PopReport;
use crate::renderer::MsField;
use crate::scene::RenderMethod;
use crate::{DensityGrid, RenderScene};
use anyhow::{ensure, Result};
use std::sync::Arc;

pub mod cda;
pub mod fld;
mod grid;
pub mod none;
pub mod pde;
pub mod pn;
pub mod pop;

/// What a method solves on: the scene (overrides applied), its density grid, how to run,
/// and what an earlier channel with the same σ_t computed.
pub struct PreparedScene<'a> {
    /// The scene.
    pub scene: &'a RenderScene,
    /// Its density grid ([`RenderScene::density_grid`]).
    pub density: &'a DensityGrid,
    /// Threads, memory limit, solver tuning and observers.
    pub options: &'a RenderOptions,
    /// The optical depth to the lights, if an earlier channel computed it.
    pub light_depth: Option<Arc<LightDepth>>,
    /// Staggered solutions on the same solve grid, to start the iteration from.
    pub guesses: &'a [&'a [f64]],
    /// The extinction on the way from the lights (σ_t′ of delta-M, σ_t without it).
    pub light_leg: &'a LightLeg,
}

/// Seconds per stage of a method (0 for the stages it does not have).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MsSeconds {
    /// The optical depth to the lights (0 when it was taken over).
    pub light_depth: f64,
    /// Resampling the coefficients and projecting the source (POP: medium sampling and
    /// initialisation).
    pub sources: f64,
    /// The solve (POP: propagation and resampling).
    pub solve: f64,
    /// The transport sweeps.
    pub sweeps: f64,
}

/// What a method hands to the renderer and the report.
#[derive(Default)]
pub struct MsSolution {
    /// The multiple-scattering radiance on the solve grid (None: single scattering only,
    /// or an empty medium).
    pub field: Option<MsField>,
    /// Unknowns of the solve (grid methods).
    pub unknowns: Option<UnknownStats>,
    /// Solver statistics (grid methods).
    pub solver: Option<SolverReport>,
    /// The optical depth to the lights the first-scatter source read (grid methods).
    pub light_depth: Option<Arc<LightDepth>>,
    /// The staggered solution vector (P_N, CDA, text PDEs), a start for another channel.
    pub staggered: Option<Vec<f64>>,
    /// POP's settings, bookkeeping and timings.
    pub pop: Option<PopReport>,
    /// Transport sweeps applied.
    pub sweeps: usize,
    /// Seconds per stage.
    pub seconds: MsSeconds,
    /// Lines for the user (`warning: …`), in order.
    pub notes: Vec<String>,
}

/// One multiple-scattering method of the render pipeline.
pub trait MultipleScattering {
    /// The report's `method`: `pn`, `cda`, `fld`, `pop`, `none` or `pde:NAME`.
    fn name(&self) -> &str;
    /// The report's `order` (P_N order, POP's highest band; None for the others).
    fn order(&self) -> Option<usize> {
        None
    }
    /// The P_N order N whose delta-M truncation the method's solve carries
    /// ([`crate::delta_m`]; P_N: N, the diffusion methods: 1, i.e. δ-Eddington); None for
    /// methods without it (POP, text PDEs, single scattering only).
    fn delta_m_order(&self) -> Option<u32> {
        None
    }
    /// Computes the multiple scattering of `prepared`.
    fn solve(&self, prepared: &PreparedScene<'_>) -> Result<MsSolution>;
}

/// The method of `scene` (`[solve] method`), or the text PDE `pde` (which is solved on the
/// `cda` route: the scene's method must then be `cda`).
pub fn method_for(
    scene: &RenderScene,
    pde: Option<&Arc<PdeKernel>>,
) -> Result<Box<dyn MultipleScattering>> {
    if let Some(p) = pde {
        ensure!(
            scene.solve.method == RenderMethod::Cda,
            "internal: a text PDE is solved on the cda route"
        );
        return Ok(Box::new(pde::TextPde::new(p.clone())));
    }
    Ok(match scene.solve.method {
        RenderMethod::Pn => Box::new(pn::Pn {
            order: scene.solve.order,
            sweep_band: scene.solve.sweep_band(scene.solve.order),
        }),
        RenderMethod::Cda => Box::new(cda::Cda {
            sweep_band: scene.solve.sweep_band(0),
        }),
        RenderMethod::Fld => Box::new(fld::Fld),
        RenderMethod::Pop => Box::new(pop::Pop {
            order: scene.solve.order,
        }),
        RenderMethod::None => Box::new(none::SingleScatteringOnly),
    })
}
