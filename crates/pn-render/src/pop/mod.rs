//! Principal-Ordinates Propagation (POP; `../shared/papers/principal-ordinates-propagation.txt`,
//! issues 20 and 52) for directional and point lights: `pn render --method pop`.
//!
//! For each directional light a grid aligned with its travel direction d covers the medium's
//! support ([`propagate::LightGrid`]); every cell holds one HG lobe about d, a magnitude L
//! and an anisotropy a. The decisions on the paper's open points (docs/pop-design.md,
//! `../shared/papers/README.md`):
//!
//! * **Initialisation (open point 3).** Not the attenuated light itself (propagating it *and*
//!   putting it into every cell would count cell i's light once per upstream cell), but the
//!   **once-scattered** light, which POP's basis represents exactly: around a directional
//!   light it is an HG lobe with a = g about d, `L_i^0 = σ_s,i · E · T_i · h`, `a_i^0 = g`,
//!   with `T_i` the exact uncollided transmittance (σ_t, [`crate::shadow`]) from the
//!   light to the cell centre, accumulated in one sweep along d per column. σ_s,i is the
//!   cell average (midpoint subsamples); `L_i^0 h²` is the power scattered once in the cell.
//! * **Where σ_s enters (open point 4):** in that source and in Eq. 4 (`a′ = a g^{σ_s t}`);
//!   the convolution of the lobe with the phase function is the renderer's `g^l` factor.
//! * **What POP hands on:** the SH moments of the **collided** radiance (scattered ≥ 1
//!   times) on the solve grid ([`accumulate`]), through the same
//!   [`crate::renderer::MsField`] as P_N; the renderers add the exact single
//!   scattering (next-event estimation with the exact transmittance), so nothing is
//!   counted twice.
//! * **Eq. 1 at g = 0 and a → 1 (open point 5):** [`hg_patch`].
//! * Points 1 and 2 (prefilter, Eq. 10) concern environment lighting (§5), not implemented.
//!
//! * **Isotropic residuum (§5.4), optional** ([`ResiduumSettings`]): after m′ iterations
//!   (Eq. 10, [`residuum_switch_iteration`]) the lobes are made isotropic and propagated
//!   until the power in flight falls below ε_L; each light in its own grid (no merge).
//!
//! * **Point lights (§6)**: a radial grid per light, the octahedral map of directions ×
//!   exponentially spaced shells ([`radial`], [`octahedral`]); the same propagation on its
//!   neighbourhood ([`propagate::Stencil`]).
//! * **Upsampling (§4.4)**: trilinear by default; the joint bilateral upsampling guided by
//!   σ_s on request ([`upsample`], `[solve] pop_upsample = "bilateral"`).
//!
//! Not implemented: environment lighting (§5.1–5.3), instant radiosity (VPLs from
//! reflective shadow maps, §6).
//!
//! Settings: `[solve] pop_resolution` (cells along the longest axis of the light-aligned box,
//! default 20 as the paper's typical 20³), `pop_iterations` (default 20: "amounts similar
//! to the propagation grid resolution along the propagation dimension", §7), and the bands
//! carried, `[solve] order` (lmax).

pub mod accumulate;
pub mod hg_patch;
pub mod octahedral;
pub mod propagate;
pub mod radial;
pub mod upsample;

use crate::lights::Light;
use crate::medium::DensityGrid;
use crate::scene::{
    PopUpsample, RenderScene, POP_DEFAULT_EPSILON_A, POP_DEFAULT_EPSILON_L, POP_DEFAULT_ITERATIONS,
    POP_DEFAULT_RESOLUTION, POP_DEFAULT_UPSAMPLE_SIGMA, POP_MAX_ITERATIONS, POP_MAX_RESOLUTION,
    POP_MAX_SHELLS,
};
use crate::shadow::Extinction;
use accumulate::BandGrid;
use anyhow::{bail, ensure};
use pn_runtime::problem::{Grid, Phase};
use pn_runtime::CellMoments;
use propagate::{IterationEnergy, LightGrid, PopMedium, ResiduumInfo, Schedule};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;
use upsample::Bilateral;

/// POP's settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PopSettings {
    /// Cells along the longest axis of each light-aligned grid (1..=512).
    pub resolution: usize,
    /// Propagation iterations (≥ 1; without the residuum).
    pub iterations: usize,
    /// Highest SH band handed to the renderer.
    pub lmax: usize,
    /// The isotropic residuum of §5.4 (None: `iterations` iterations with lobes).
    pub residuum: Option<ResiduumSettings>,
}

/// The isotropic residuum's thresholds (§5.4).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ResiduumSettings {
    /// ε_a: lobes count as isotropic once their anisotropy would have decayed below it; the
    /// switch iteration m′ follows from Eq. 10 (the paper: "around 0.1, or even higher").
    pub epsilon_a: f64,
    /// ε_L: the isotropic iteration stops when the power in flight is at most ε_L times the
    /// injected power.
    pub epsilon_l: f64,
}

impl Default for ResiduumSettings {
    fn default() -> Self {
        Self {
            epsilon_a: POP_DEFAULT_EPSILON_A,
            epsilon_l: POP_DEFAULT_EPSILON_L,
        }
    }
}

impl Default for PopSettings {
    /// The paper's typical 20³ grid, 20 iterations, bands up to 3, no residuum.
    fn default() -> Self {
        Self {
            resolution: POP_DEFAULT_RESOLUTION,
            iterations: POP_DEFAULT_ITERATIONS,
            lmax: 3,
            residuum: None,
        }
    }
}

/// m′ of Eq. 10, the iteration after which the lobes count as isotropic: light that has
/// travelled t = m′ h through the mean scattering coefficient σ̄_s has anisotropy
/// `â g^{σ̄_s t} = ε_a`, with â = g (the once-scattered lobes POP starts from). At least the
/// grid's cells along the light (the paper: so that light from the first plane reaches the
/// rest), at most [`POP_MAX_ITERATIONS`]. σ̄_s is the mean over the cells with σ_s > 0 (the
/// medium, not the empty corners of the light-aligned box).
pub fn residuum_switch_iteration(grid: &LightGrid, medium: &PopMedium, epsilon_a: f64) -> usize {
    let along = grid.res[2];
    let (sum, count) = medium
        .sigma_s
        .iter()
        .filter(|s| **s > 0.0)
        .fold((0.0, 0usize), |(a, c), s| (a + s, c + 1));
    let mean = sum / count as f64;
    eq10_switch(
        along,
        medium.g,
        (count > 0).then_some(mean * grid.h),
        epsilon_a,
    )
}

/// Eq. 10 with the mean optical depth that one step crosses, `tau_step` (σ̄_s h on the
/// light-aligned grid; None: no medium), at least `along` and at most
/// [`POP_MAX_ITERATIONS`]: [`residuum_switch_iteration`].
pub fn eq10_switch(along: usize, g: f64, tau_step: Option<f64>, epsilon_a: f64) -> usize {
    let Some(tau) = tau_step.filter(|_| g > epsilon_a) else {
        return along.min(POP_MAX_ITERATIONS);
    };
    // (ln ε_a − ln â) / ln g / (σ̄_s h); ln g < 0 and ln ε_a < ln â, so this is positive.
    let m = (epsilon_a.ln() - g.ln()) / g.ln() / tau;
    let m = if m.is_finite() {
        m.ceil().min(POP_MAX_ITERATIONS as f64) as usize
    } else {
        POP_MAX_ITERATIONS
    };
    m.max(along).min(POP_MAX_ITERATIONS)
}

impl PopSettings {
    /// Checks the ranges: resolution in 1..=512, iterations in 1..=[`POP_MAX_ITERATIONS`],
    /// lmax ≤ [`pn_stencil::MAX_ORDER`].
    pub fn validate(&self) -> anyhow::Result<()> {
        ensure!(
            (1..=POP_MAX_RESOLUTION).contains(&self.resolution),
            "POP grid resolution must lie in 1..={POP_MAX_RESOLUTION}, got {}",
            self.resolution
        );
        ensure!(
            (1..=POP_MAX_ITERATIONS).contains(&self.iterations),
            "POP iterations must lie in 1..={POP_MAX_ITERATIONS}, got {}",
            self.iterations
        );
        if let Some(r) = self.residuum {
            ensure!(
                r.epsilon_a.is_finite() && r.epsilon_a > 0.0 && r.epsilon_a < 1.0,
                "POP residuum: epsilon_a must lie in (0, 1), got {}",
                r.epsilon_a
            );
            ensure!(
                r.epsilon_l.is_finite() && r.epsilon_l > 0.0 && r.epsilon_l < 1.0,
                "POP residuum: epsilon_l must lie in (0, 1), got {}",
                r.epsilon_l
            );
        }
        ensure!(
            self.lmax <= pn_stencil::MAX_ORDER,
            "POP bands: lmax must be at most {}, got {}",
            pn_stencil::MAX_ORDER,
            self.lmax
        );
        Ok(())
    }
}

/// The phase function's g for POP: isotropic is g = 0; HG needs g in [0, 1) (the paper's
/// model has no backscattering lobes, §4; g → 1 is handled as a delta lobe by
/// [`hg_patch`]).
pub fn phase_g(phase: &Phase) -> anyhow::Result<f64> {
    match phase {
        Phase::Isotropic => Ok(0.0),
        Phase::HenyeyGreenstein(g) => {
            ensure!(
                g.is_finite() && (0.0..1.0).contains(g),
                "POP needs a Henyey–Greenstein g in [0, 1) (no backward lobes in the paper's \
                 model), got g = {g}"
            );
            Ok(*g)
        }
        other => anyhow::bail!(
            "POP supports isotropic and Henyey–Greenstein phases (the paper's lobes), got {}",
            other.describe()
        ),
    }
}

/// The energy balance and grid of one light (powers in W: `Σ L h²`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PopLightReport {
    /// Index of the light in the scene.
    pub light: usize,
    /// "directional" (a light-aligned grid) or "point" (a radial grid).
    pub kind: &'static str,
    /// The radial grid of a point light (None for a directional light).
    pub radial: Option<RadialReport>,
    /// Its travel direction (unit); for a point light the radial grid's pole.
    pub direction: [f64; 3],
    /// Cells of its grid along u, v, d (a point light: the octahedral map's two sides and
    /// the shells).
    pub grid_res: [usize; 3],
    /// Cell side (a point light: the innermost shell's thickness).
    pub cell_size: f64,
    /// Midpoint subsamples per axis and cell used for the cell averages of σ_s, σ_a.
    pub subsamples: usize,
    /// Once-scattered power injected, `Σ σ_s E T h³`.
    pub injected: f64,
    /// Left through the grid's faces, all iterations.
    pub left_grid: f64,
    /// Absorbed, all iterations.
    pub absorbed: f64,
    /// Still in flight after the last iteration (truncation of the iteration count).
    pub in_flight_final: f64,
    /// `in_flight_final / injected`.
    pub in_flight_final_fraction: f64,
    /// Largest |in flight before − after − left − absorbed| over the iterations, relative
    /// to `injected` (rounding only).
    pub max_relative_imbalance: f64,
    /// What the isotropic residuum did (None without it).
    pub residuum: Option<ResiduumInfo>,
    /// One entry per iteration.
    pub energy: Vec<IterationEnergy>,
}

/// A point light's radial grid (`report.json` → "pop" → "lights" → "radial").
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RadialReport {
    /// The light's position.
    pub position: [f64; 3],
    /// Whether the light lies inside (or on) the medium's box: the innermost shell then
    /// stands for the ball down to the light.
    pub inside: bool,
    /// Radius of the innermost shell's inner face (the distance to the medium's box, or for
    /// a light inside it half the smallest voxel side).
    pub r_min: f64,
    /// Radius of the outermost shell's outer face.
    pub r_max: f64,
    /// Radial shells.
    pub shells: usize,
    /// Cells per side of the octahedral map.
    pub angular: usize,
    /// `ln q`, the logarithmic shell spacing (`Δr/r ≈ ln q`).
    pub log_q: f64,
    /// Angular cells (of `angular²`) with medium in some shell: how finely the map resolves
    /// the medium as seen from the light.
    pub medium_directions: usize,
}

/// What POP does beyond the directional-light core: point lights' shells and the
/// upsampling (`[solve] pop_shells`, `pop_upsample`, `pop_upsample_sigma`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PopOptions {
    /// Radial shells of a point light's grid (None: cells about as long as wide).
    pub shells: Option<usize>,
    /// Trilinear or the joint bilateral upsampling of §4.4.
    pub upsample: PopUpsample,
    /// The bilateral range kernel's width relative to the largest σ_s.
    pub upsample_sigma: f64,
}

impl Default for PopOptions {
    /// Automatic shells, trilinear resampling.
    fn default() -> Self {
        Self {
            shells: None,
            upsample: PopUpsample::Trilinear,
            upsample_sigma: POP_DEFAULT_UPSAMPLE_SIGMA,
        }
    }
}

impl PopOptions {
    /// Checks the ranges: shells in 1..=[`POP_MAX_SHELLS`], a finite positive σ_r.
    pub fn validate(&self) -> anyhow::Result<()> {
        if let Some(n) = self.shells {
            ensure!(
                (1..=POP_MAX_SHELLS).contains(&n),
                "pop_shells must lie in 1..={POP_MAX_SHELLS}, got {n}"
            );
        }
        ensure!(
            self.upsample_sigma.is_finite() && self.upsample_sigma > 0.0,
            "pop_upsample_sigma must be finite and positive, got {}",
            self.upsample_sigma
        );
        Ok(())
    }
}

/// Seconds per POP stage (all lights).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PopSeconds {
    /// Sampling σ_s, σ_a onto the light grids.
    pub medium: f64,
    /// Uncollided transmittance sweep and the once-scattered source.
    pub initialization: f64,
    /// The iterations (Eqs. 2, 4–6) and the band accumulation.
    pub propagation: f64,
    /// Projection to SH moments and resampling onto the solve grid.
    pub resampling: f64,
}

/// What POP did (`report.json` → "pop").
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PopReport {
    /// Settings used.
    pub settings: PopSettings,
    /// Point-light shells and upsampling used.
    pub options: PopOptions,
    /// g of the phase function.
    pub g: f64,
    /// Per directional light.
    pub lights: Vec<PopLightReport>,
    /// Seconds per stage.
    pub seconds: PopSeconds,
    /// Lights POP ignores, an empty medium.
    pub warnings: Vec<String>,
}

/// POP's result on the solve grid.
#[derive(Clone, Debug)]
pub struct PopRun {
    /// Moments of the collided radiance at the solve-grid cell centres.
    pub moments: CellMoments,
    /// Bookkeeping and timings.
    pub report: PopReport,
}

/// One propagated light: its grid and accumulated band amplitudes (for tests and studies).
#[derive(Clone, Debug)]
pub struct LightSolution {
    /// The light-aligned grid.
    pub grid: LightGrid,
    /// The medium on it.
    pub medium: PopMedium,
    /// Band amplitudes and bookkeeping.
    pub propagated: propagate::Propagated,
    /// Midpoint subsamples per axis.
    pub subsamples: usize,
}

/// Most medium lookups for the cell averages (cells × subsamples³).
const MAX_LOOKUPS: usize = 1 << 26;

/// Cell averages of σ_s and σ_a on `grid` (midpoint rule with `k³` subsamples per cell, k
/// the ratio of the POP cell to the smallest density voxel, 1..=4: the paper's
/// "downscaled version of the volume", §4.2).
fn sample_medium(
    scene: &RenderScene,
    density: &DensityGrid,
    grid: &LightGrid,
    g: f64,
) -> anyhow::Result<(PopMedium, usize)> {
    let hmin = density.h().iter().fold(f64::INFINITY, |m, v| m.min(*v));
    let mut k = ((grid.h / hmin).ceil() as usize).clamp(1, 4);
    while k > 1 && grid.cells().saturating_mul(k * k * k) > MAX_LOOKUPS {
        k -= 1;
    }
    let [nx, ny, _] = grid.res;
    let plane = nx * ny;
    let n = grid.cells();
    let mut sigma_s = vec![0.0; n];
    let mut sigma_a = vec![0.0; n];
    let kf = k as f64;
    sigma_s
        .par_chunks_mut(plane)
        .zip(sigma_a.par_chunks_mut(plane))
        .enumerate()
        .for_each(|(kk, (ss, sa))| {
            for j in 0..ny {
                for i in 0..nx {
                    let (mut st_sum, mut ss_sum) = (0.0, 0.0);
                    for a in 0..k {
                        for b in 0..k {
                            for c in 0..k {
                                let s = [a, b, c].map(|v| (v as f64 + 0.5) / kf - 0.5);
                                let off = [i as f64 + s[0], j as f64 + s[1], kk as f64 + s[2]];
                                let x = [0, 1, 2].map(|q| {
                                    grid.origin[q]
                                        + (0..3)
                                            .map(|ax| (off[ax] + 0.5) * grid.h * grid.axes[ax][q])
                                            .sum::<f64>()
                                });
                                let (t, s) = scene.medium.coefficients_at(density, x);
                                st_sum += t;
                                ss_sum += s;
                            }
                        }
                    }
                    let inv = 1.0 / (kf * kf * kf);
                    let o = j * nx + i;
                    ss[o] = ss_sum * inv;
                    sa[o] = ((st_sum - ss_sum) * inv).max(0.0);
                }
            }
        });
    if let Some(bad) = sigma_s.iter().chain(&sigma_a).find(|v| !v.is_finite()) {
        bail!("POP: the medium has a non-finite coefficient ({bad}) on the propagation grid");
    }
    Ok((
        PopMedium {
            sigma_s,
            sigma_a,
            g,
        },
        k,
    ))
}

/// `T_i` at every cell centre: exact optical depth from the light to the first centre of
/// each column, then centre to centre along d (one sweep, [`Extinction::optical_depth`]).
fn transmittance(ext: &Extinction, grid: &LightGrid) -> Vec<f64> {
    let [nx, ny, nz] = grid.res;
    let d = grid.axes[2];
    let back = d.map(|c| -c);
    let columns: Vec<Vec<f64>> = (0..nx * ny)
        .into_par_iter()
        .map(|c| {
            let (i, j) = (c % nx, c / nx);
            let mut col = Vec::with_capacity(nz);
            let mut x = grid.centre([i, j, 0]);
            let mut tau = ext.optical_depth(x, back, f64::INFINITY);
            col.push((-tau).exp());
            for k in 1..nz {
                tau += ext.optical_depth(x, d, grid.h);
                x = grid.centre([i, j, k]);
                col.push((-tau).exp());
            }
            col
        })
        .collect();
    let mut t = vec![0.0; grid.cells()];
    for (c, col) in columns.iter().enumerate() {
        let (i, j) = (c % nx, c / nx);
        for (k, v) in col.iter().enumerate() {
            t[grid.index(i, j, k)] = *v;
        }
    }
    t
}

/// Propagates one directional light (travel `direction`, irradiance `irradiance`) through
/// the scene's medium on a grid of `settings.resolution` cells over the density's support.
/// `None` for an empty medium.
pub fn solve_light(
    scene: &RenderScene,
    density: &DensityGrid,
    direction: [f64; 3],
    irradiance: f64,
    settings: &PopSettings,
    seconds: &mut PopSeconds,
) -> anyhow::Result<Option<LightSolution>> {
    settings.validate()?;
    let g = phase_g(&scene.phase)?;
    ensure!(
        irradiance.is_finite() && irradiance >= 0.0,
        "POP: irradiance must be finite and non-negative, got {irradiance}"
    );
    let Some((lo, hi)) = density.support() else {
        return Ok(None);
    };
    let t0 = Instant::now();
    let grid = LightGrid::around_box(direction, lo, hi, settings.resolution)?;
    // Per cell: σ_s, σ_a, T (and its columns while sweeping), source, two halves, L and a
    // twice, three patch fractions and lmax + 1 band amplitudes (f64 each).
    let bytes = grid.cells() as u128 * 8 * (14 + settings.lmax as u128 + 1);
    let limit = pn_runtime::memory_estimate::default_limit_bytes() as u128;
    ensure!(
        bytes <= limit,
        "POP: the {:?} grid needs about {:.1} GiB, more than the default memory limit of \
         {:.1} GiB: lower the POP resolution",
        grid.res,
        bytes as f64 / (1u64 << 30) as f64,
        limit as f64 / (1u64 << 30) as f64
    );
    let (medium, subsamples) = sample_medium(scene, density, &grid, g)?;
    seconds.medium += t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let ext = Extinction {
        grid: density,
        scale: scene.medium.sigma_t_scale,
    };
    let t = transmittance(&ext, &grid);
    let source: Vec<f64> = medium
        .sigma_s
        .iter()
        .zip(&t)
        .map(|(s, t)| s * irradiance * t * grid.h)
        .collect();
    seconds.initialization += t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let schedule = match settings.residuum {
        None => Schedule::Fixed(settings.iterations),
        Some(r) => Schedule::Residuum {
            anisotropic: residuum_switch_iteration(&grid, &medium, r.epsilon_a),
            epsilon_l: r.epsilon_l,
            max_total: POP_MAX_ITERATIONS,
        },
    };
    let propagated =
        propagate::propagate_scheduled(&grid, &medium, &source, g, settings.lmax, schedule)?;
    seconds.propagation += t2.elapsed().as_secs_f64();
    Ok(Some(LightSolution {
        grid,
        medium,
        propagated,
        subsamples,
    }))
}

/// POP for every light of `scene` with the default [`PopOptions`]: [`pop_field_with`].
pub fn pop_field(
    scene: &RenderScene,
    density: &DensityGrid,
    target: &Grid,
    settings: &PopSettings,
) -> anyhow::Result<PopRun> {
    pop_field_with(scene, density, target, settings, &PopOptions::default())
}

/// How a light's propagated band amplitudes reach the solve grid `target`: trilinear, or
/// with the joint bilateral upsampling guided by `guide` (σ_s) where `sigma` is given.
struct Resampling<'a> {
    target: &'a Grid,
    guide: &'a (dyn Fn([f64; 3]) -> f64 + Sync),
    sigma: Option<f64>,
}

impl Resampling<'_> {
    /// Adds `p`, propagated on `grid` (light-aligned or radial), to `moments`, timed as
    /// resampling.
    fn moments<G: BandGrid + propagate::Stencil>(
        &self,
        grid: &G,
        p: &propagate::Propagated,
        moments: &mut CellMoments,
        seconds: &mut PopSeconds,
    ) {
        let t = Instant::now();
        let cells = propagate::Stencil::cells(grid);
        let bil = self
            .sigma
            .and_then(|s| Bilateral::new(cells, |c| grid.centre_of(c), self.guide, s));
        accumulate::add_moments(grid, &p.bands, p.lmax, self.target, moments, bil.as_ref());
        seconds.resampling += t.elapsed().as_secs_f64();
    }
}

/// POP for every light of `scene` (a light-aligned grid per directional light, a radial
/// grid per point light): the moments (l ≤ `settings.lmax`) of the collided radiance at the
/// cell centres of `target` (the solve grid) and the report.
pub fn pop_field_with(
    scene: &RenderScene,
    density: &DensityGrid,
    target: &Grid,
    settings: &PopSettings,
    options: &PopOptions,
) -> anyhow::Result<PopRun> {
    settings.validate()?;
    options.validate()?;
    let g = phase_g(&scene.phase)?;
    let pc = (settings.lmax + 1) * (settings.lmax + 1);
    let mut moments = CellMoments {
        res: target.res,
        per_cell: pc,
        data: vec![0.0; target.cells() * pc],
    };
    let mut seconds = PopSeconds::default();
    let mut lights = Vec::new();
    let mut warnings = Vec::new();
    let guide = |x: [f64; 3]| scene.medium.coefficients_at(density, x).1;
    let sigma = match options.upsample {
        PopUpsample::Trilinear => None,
        PopUpsample::Bilateral => Some(options.upsample_sigma),
    };
    for (n, light) in scene.lights.iter().enumerate() {
        let (report, propagated) = match light {
            Light::Directional {
                direction,
                irradiance,
            } => {
                let Some(sol) = solve_light(
                    scene,
                    density,
                    *direction,
                    *irradiance,
                    settings,
                    &mut seconds,
                )?
                else {
                    continue;
                };
                let add = Resampling {
                    target,
                    guide: &guide,
                    sigma,
                };
                add.moments(&sol.grid, &sol.propagated, &mut moments, &mut seconds);
                (light_report(n, &sol), sol.propagated)
            }
            Light::Point { position, power } => {
                let Some(sol) = radial::solve_point_light(
                    scene,
                    density,
                    *position,
                    *power,
                    settings,
                    options.shells,
                    &mut seconds,
                )?
                else {
                    continue;
                };
                let add = Resampling {
                    target,
                    guide: &guide,
                    sigma,
                };
                add.moments(&sol.grid, &sol.propagated, &mut moments, &mut seconds);
                (point_report(n, &sol), sol.propagated)
            }
        };
        if let Some(r) = propagated
            .residuum
            .as_ref()
            .filter(|r| !r.reached_epsilon_l)
        {
            warnings.push(format!(
                "POP residuum, light {n}: the power in flight did not fall to epsilon_l within \
                 {POP_MAX_ITERATIONS} iterations ({} isotropic); {:.3e} of the injected power \
                 is still in flight",
                r.isotropic_iterations,
                propagated.energy.last().map_or(1.0, |e| e.in_flight_after)
                    / propagated.injected.max(f64::MIN_POSITIVE)
            ));
        }
        lights.push(report);
    }
    if lights.is_empty() && warnings.is_empty() {
        warnings.push("POP: no light or an empty medium: no multiple scattering".into());
    }
    Ok(PopRun {
        moments,
        report: PopReport {
            settings: *settings,
            options: *options,
            g,
            lights,
            seconds,
            warnings,
        },
    })
}

/// The bookkeeping of one propagated light.
pub fn light_report(light: usize, sol: &LightSolution) -> PopLightReport {
    let mut r = balance(light, &sol.propagated);
    r.direction = sol.grid.axes[2];
    r.grid_res = sol.grid.res;
    r.cell_size = sol.grid.h;
    r.subsamples = sol.subsamples;
    r
}

/// The energy balance of one propagated light (the grid fields left for the caller).
fn balance(light: usize, p: &propagate::Propagated) -> PopLightReport {
    let left: f64 = p.energy.iter().map(|e| e.left_grid).sum();
    let absorbed: f64 = p.energy.iter().map(|e| e.absorbed).sum();
    let final_ = p.energy.last().map_or(p.injected, |e| e.in_flight_after);
    let rel = |v: f64| {
        if p.injected > 0.0 {
            v / p.injected
        } else {
            0.0
        }
    };
    PopLightReport {
        light,
        kind: "directional",
        radial: None,
        direction: [0.0; 3],
        grid_res: [0; 3],
        cell_size: 0.0,
        subsamples: 0,
        injected: p.injected,
        left_grid: left,
        absorbed,
        in_flight_final: final_,
        in_flight_final_fraction: rel(final_),
        max_relative_imbalance: p
            .energy
            .iter()
            .map(|e| rel(e.imbalance().abs()))
            .fold(0.0, f64::max),
        residuum: p.residuum.clone(),
        energy: p.energy.clone(),
    }
}

/// The bookkeeping of one propagated point light (as [`light_report`]; `direction` is the
/// radial grid's pole, `cell_size` the innermost shell's thickness).
pub fn point_report(light: usize, sol: &radial::PointSolution) -> PopLightReport {
    let p = &sol.propagated;
    let grid = &sol.grid;
    let shells = grid.shells();
    let medium_directions = (0..grid.map.n * grid.map.n)
        .filter(|a| (0..shells).any(|k| sol.medium.sigma_s[k * grid.map.n * grid.map.n + a] > 0.0))
        .count();
    let mut r = balance(light, p);
    r.kind = "point";
    r.direction = grid.axes[2];
    r.grid_res = grid.res();
    r.cell_size = grid.radii[1] - grid.radii[0];
    r.subsamples = sol.subsamples;
    r.radial = Some(RadialReport {
        position: grid.position,
        inside: grid.inside,
        r_min: grid.radii[0],
        r_max: grid.radii[shells],
        shells,
        angular: grid.map.n,
        log_q: grid.log_q,
        medium_directions,
    });
    r
}
