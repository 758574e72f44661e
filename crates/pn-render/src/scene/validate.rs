//! The checks of a render scene's values: finite vectors, non-negative numbers, the solve
//! and render settings' ranges.

use super::*;
use anyhow::ensure;

pub(super) fn finite3(name: &str, v: [f64; 3]) -> anyhow::Result<()> {
    ensure!(
        v.iter().all(|c| c.is_finite()),
        "{name} must be finite, got {v:?}"
    );
    Ok(())
}

pub(super) fn nonneg(name: &str, v: f64) -> anyhow::Result<()> {
    ensure!(
        v.is_finite() && v >= 0.0,
        "{name} must be finite and non-negative, got {v}"
    );
    Ok(())
}

impl SolveSettings {
    /// The absorber's ramp in solve cells: [`Self::absorbing_layer`] when set, else
    /// [`Self::absorber_width`] × the largest solve resolution.
    pub fn ramp_cells(&self) -> f64 {
        match self.absorbing_layer {
            Some(n) => n as f64,
            None => self.absorber_width * self.resolution.iter().copied().max().unwrap_or(0) as f64,
        }
    }

    /// Cells added around the cropped medium: the empty margin plus the absorbing layer
    /// (the ramp rounded up).
    pub fn padding(&self) -> usize {
        self.margin + self.layer_cells()
    }

    /// The ramp rounded up to whole cells: the layer at the grid's faces and the padding.
    pub fn layer_cells(&self) -> usize {
        self.ramp_cells().ceil() as usize
    }

    /// Checks order, resolution, tolerance, threshold and the POP settings.
    pub fn validate(&self) -> anyhow::Result<()> {
        let max = pn_stencil::MAX_ORDER;
        ensure!(
            (1..=max).contains(&self.order),
            "order must lie in 1..={max}, got {}",
            self.order
        );
        ensure!(
            self.resolution.iter().all(|&n| (1..=4096).contains(&n)),
            "solve resolution must be between 1 and 4096 per axis, got {:?}",
            self.resolution
        );
        ensure!(
            self.margin <= 64,
            "margin must be at most 64 cells, got {}",
            self.margin
        );
        ensure!(
            self.absorber_width.is_finite() && (0.0..=1.0).contains(&self.absorber_width),
            "absorber_width must lie in [0, 1] (a fraction of the solve cells across the \
             medium box), got {}",
            self.absorber_width
        );
        ensure!(
            self.ramp_cells() <= 64.0,
            "the absorber's ramp must be at most 64 cells, got {} (absorbing_layer, or \
             absorber_width × resolution)",
            self.ramp_cells()
        );
        ensure!(
            self.tolerance.is_finite() && self.tolerance > 0.0 && self.tolerance < 1.0,
            "tolerance must lie in (0, 1), got {}",
            self.tolerance
        );
        if let Some(t) = self.sigma_t_min {
            ensure!(
                t.is_finite() && t > 0.0,
                "sigma_t_min must be finite and non-negative, got {t}"
            );
        }
        ensure!(
            (1..=POP_MAX_RESOLUTION).contains(&self.pop_resolution),
            "pop_resolution must lie in 1..={POP_MAX_RESOLUTION}, got {}",
            self.pop_resolution
        );
        ensure!(
            (1..=POP_MAX_ITERATIONS).contains(&self.pop_iterations),
            "pop_iterations must lie in 1..={POP_MAX_ITERATIONS}, got {}",
            self.pop_iterations
        );
        if let Some(n) = self.pop_shells {
            ensure!(
                (1..=POP_MAX_SHELLS).contains(&n),
                "pop_shells must lie in 1..={POP_MAX_SHELLS}, got {n}"
            );
        }
        ensure!(
            self.pop_upsample_sigma.is_finite() && self.pop_upsample_sigma > 0.0,
            "pop_upsample_sigma must be finite and positive, got {}",
            self.pop_upsample_sigma
        );
        for (name, v) in [
            ("pop_epsilon_a", self.pop_epsilon_a),
            ("pop_epsilon_l", self.pop_epsilon_l),
        ] {
            ensure!(
                v.is_finite() && v > 0.0 && v < 1.0,
                "{name} must lie in (0, 1), got {v}"
            );
        }
        ensure!(
            self.sweeps <= MAX_SWEEPS,
            "sweeps must be at most {MAX_SWEEPS}, got {}",
            self.sweeps
        );
        if let Some(n) = self.sweep_quadrature {
            ensure!(
                (1..=64).contains(&n),
                "sweep_quadrature must lie in 1..=64 (Gauss nodes in cos θ), got {n}"
            );
        }
        if let Some(l) = self.sweep_order {
            ensure!(
                l <= MAX_SWEEP_ORDER,
                "sweep_order must be at most {MAX_SWEEP_ORDER}, got {l}"
            );
        }
        if let Some(b) = self.sweep_bands {
            ensure!(
                b < 2 * self.sweep_nodes(),
                "sweep_bands = {b} needs sweep_quadrature ≥ {} (the angular rule resolves bands \
                 up to 2 × sweep_quadrature − 1), got {}",
                b / 2 + 1,
                self.sweep_nodes()
            );
        }
        if self.boundary == SolveBoundary::Marshak {
            ensure!(
                self.method == RenderMethod::Pn && self.order % 2 == 1,
                "boundary = \"marshak\" needs method \"pn\" with an odd order (the staggered \
                 Marshak rows), got method {:?} order {}",
                self.method.name(),
                self.order
            );
        }
        Ok(())
    }
}

impl RenderSettings {
    /// Checks the sample count, the ray count (a square number in 1..=[`MAX_RAYS`]), the
    /// step (in [`STEP_RANGE`]), the cutoff (in [0, 1)) and the sky grid (in [0,
    /// [`MAX_SKY_GRID`]]).
    pub fn validate(&self) -> anyhow::Result<()> {
        ensure!(
            (1..=MAX_SPP).contains(&self.spp),
            "spp must lie in 1..={MAX_SPP}, got {}",
            self.spp
        );
        let k = (self.rays as f64).sqrt().round() as usize;
        ensure!(
            (1..=MAX_RAYS).contains(&self.rays) && k * k == self.rays,
            "rays (camera rays per pixel) must be a square number k² in 1..={MAX_RAYS} \
             (1, 4, 9, 16, …: a k×k pattern), got {}",
            self.rays
        );
        let (lo, hi) = STEP_RANGE;
        ensure!(
            self.step.is_finite() && (lo..=hi).contains(&self.step),
            "step must lie in [{lo}, {hi}] voxel sides, got {}",
            self.step
        );
        ensure!(
            self.cutoff.is_finite() && (0.0..1.0).contains(&self.cutoff),
            "cutoff (transmittance at which a ray stops) must lie in [0, 1), got {}",
            self.cutoff
        );
        ensure!(
            self.sky_grid.is_finite() && (0.0..=MAX_SKY_GRID).contains(&self.sky_grid),
            "sky_grid (voxel sides between the nodes of the sky's single-scattering grid; 0: \
             every sky light at every step) must lie in [0, {MAX_SKY_GRID}], got {}",
            self.sky_grid
        );
        Ok(())
    }
}
