//! POP (Principal-Ordinates Propagation, [`crate::pop`]): no linear system; the moments of
//! the collided radiance go onto the cropped solve grid.

use super::{MsSeconds, MsSolution, MultipleScattering, PreparedScene};
use crate::pop::{pop_field_with, PopOptions, PopSettings, ResiduumSettings};
use crate::renderer::MsField;
use crate::solve_setup::solve_grid;
use anyhow::Result;

/// POP, handing bands up to `order` to the renderer.
pub struct Pop {
    /// The highest spherical-harmonic band handed to the renderer.
    pub order: usize,
}

impl MultipleScattering for Pop {
    fn name(&self) -> &str {
        "pop"
    }

    fn order(&self) -> Option<usize> {
        Some(self.order)
    }

    fn solve(&self, p: &PreparedScene<'_>) -> Result<MsSolution> {
        let (scene, s) = (p.scene, &p.scene.solve);
        anyhow::ensure!(
            scene.sky.is_none(),
            "POP does not take sky lights yet (its environment-map ordinates, the paper's §5, \
             are issue 52): use --method pn, cda or fld with an envmap or constant sky"
        );
        let Some(sg) = solve_grid(p.density, s.resolution, s.padding(), true)? else {
            return Ok(MsSolution::default());
        };
        let settings = PopSettings {
            resolution: s.pop_resolution,
            iterations: s.pop_iterations,
            lmax: self.order,
            residuum: s.pop_residuum.then_some(ResiduumSettings {
                epsilon_a: s.pop_epsilon_a,
                epsilon_l: s.pop_epsilon_l,
            }),
        };
        let options = PopOptions {
            shells: s.pop_shells,
            upsample: s.pop_upsample,
            upsample_sigma: s.pop_upsample_sigma,
        };
        let run = pn_runtime::with_threads(p.options.threads, || {
            pop_field_with(scene, p.density, &sg.grid, &settings, &options)
        })??;
        let t = &run.report.seconds;
        let seconds = MsSeconds {
            sources: t.medium + t.initialization,
            solve: t.propagation + t.resampling,
            ..MsSeconds::default()
        };
        Ok(MsSolution {
            field: Some(
                MsField::new(sg.grid, run.moments, scene.phase.clone())?
                    .with_lookup(scene.render.ms_lookup),
            ),
            pop: Some(run.report),
            seconds,
            ..MsSolution::default()
        })
    }
}
