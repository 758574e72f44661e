//! The render's report (`report.json` of `pn render`, the `report` of the Python package):
//! statistics, settings and seconds per stage, as data.

use crate::pop::PopReport;
use serde::Serialize;

/// Unknowns of the solve (what cropping and a coarse grid save; docs/solvers.md).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UnknownStats {
    /// Solved: the cropped grid at the solve resolution.
    pub solved: u128,
    /// The whole medium box (plus margin) at the solve resolution.
    pub uncropped: u128,
    /// The cropped grid at the density-grid resolution.
    pub cropped_at_density_resolution: u128,
    /// The whole box at the density-grid resolution.
    pub uncropped_at_density_resolution: u128,
    /// Solve-grid cells per axis (cropped).
    pub solve_grid_res: [usize; 3],
    /// Solve-grid box.
    pub solve_grid_min: [f64; 3],
    /// Solve-grid box.
    pub solve_grid_max: [f64; 3],
}

/// Seconds per stage.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Timings {
    /// Building the density grid.
    pub density: f64,
    /// Resampling σ_t, σ_s and projecting the first-scatter source.
    pub sources: f64,
    /// Assembly + linear (or FLD) solve.
    pub solve: f64,
    /// The transport sweeps after the solve ([`RenderReport::sweeps`]).
    pub sweeps: f64,
    /// The optical depth from the medium to the lights ([`crate::light_depth::LightDepth`]: light-frame planes
    /// for directional lights, voxel centres near the medium for point lights), once per
    /// render: the first-scatter source and the deterministic renderer's camera rays read
    /// it. 0 when a channel took it over from an earlier one with the same σ_t, and for the
    /// Monte Carlo renderer without a solve.
    pub light_depth: f64,
    /// Rendering (all views).
    pub render: f64,
    /// Everything.
    pub total: f64,
}

/// Solver statistics.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SolverReport {
    /// Solver name.
    pub solver: String,
    /// Stencil name.
    pub stencil: String,
    /// Iterations.
    pub iterations: usize,
    /// Final relative residual.
    pub relative_residual: f64,
    /// Tolerance.
    pub tolerance: f64,
    /// Whether it converged.
    pub converged: bool,
    /// σ_t threshold used (P_N, CDA).
    pub sigma_t_min: Option<f64>,
    /// Whether it was chosen automatically (vacuum present).
    pub sigma_t_min_auto: bool,
}

/// `report.json` of `pn render`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RenderReport {
    /// Scene name.
    pub scene: String,
    /// Method.
    pub method: String,
    /// P_N order (pn only).
    pub order: Option<usize>,
    /// The renderer: "deterministic" or "montecarlo".
    pub renderer: String,
    /// Camera rays per pixel (deterministic renderer: the k×k pattern; Monte Carlo: spp).
    pub rays_per_pixel: usize,
    /// Step of the deterministic renderer in voxel sides (None for Monte Carlo).
    pub step: Option<f64>,
    /// The step in world units (None for Monte Carlo).
    pub step_length: Option<f64>,
    /// Transmittance cutoff of the deterministic renderer (None for Monte Carlo).
    pub cutoff: Option<f64>,
    /// Deterministic renderer: transmittance to the lights traced at every step (true) or
    /// from the light-depth grid (false; None for Monte Carlo).
    pub exact_transmittance: Option<bool>,
    /// Density filter ("trilinear" or "nearest").
    pub filter: String,
    /// Samples per pixel (Monte Carlo renderer; the scene's value otherwise).
    pub spp: usize,
    /// Seed (Monte Carlo renderer).
    pub seed: u64,
    /// Image size.
    pub width: usize,
    /// Image size.
    pub height: usize,
    /// Density-grid resolution.
    pub density_resolution: [usize; 3],
    /// How the image was integrated.
    pub tracking: String,
    /// Unknowns (None for method none or an empty medium).
    pub unknowns: Option<UnknownStats>,
    /// Solver statistics.
    pub solver: Option<SolverReport>,
    /// Transport sweeps applied to the solution before rendering
    /// (`pn_render::transport_sweep`; 0 without a solve and for method pop).
    pub sweeps: usize,
    /// Method pop: settings, per-light energy bookkeeping per iteration, seconds per stage
    /// (`seconds.sources` is its medium sampling + initialisation, `seconds.solve` its
    /// propagation + resampling).
    pub pop: Option<PopReport>,
    /// Seconds per stage.
    pub seconds: Timings,
    /// Mean pixel value.
    pub mean_radiance: f64,
    /// Root-mean-square of the per-pixel standard errors.
    pub rms_standard_error: f64,
    /// Peak resident memory of the process (bytes).
    pub peak_memory_bytes: Option<u64>,
    /// Worker threads.
    pub threads: usize,
    /// The turntable views (empty for a single view).
    pub views: Vec<ViewReport>,
    /// Warnings (also printed on stderr): an empty medium, a medium out of view.
    pub warnings: Vec<String>,
    /// The `--set SECTION.KEY=VALUE` overrides of the scene file, in order (empty without).
    pub overrides: Vec<String>,
    /// A coloured scene's channels, R, G, B (empty for a grey scene); the fields above then
    /// describe the mean image and sum the channels' times.
    pub channels: Vec<ChannelReport>,
}

/// One view of a turntable.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ViewReport {
    /// View index k.
    pub index: usize,
    /// Rotation angle 2πk/K about the axis through the target parallel to up (degrees).
    pub angle_deg: f64,
    /// Camera position of the view.
    pub position: [f64; 3],
    /// Seconds to render it.
    pub render_seconds: f64,
    /// Mean pixel value.
    pub mean_radiance: f64,
}

/// One channel of a coloured render in `report.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelReport {
    /// "R", "G" or "B".
    pub channel: String,
    /// σ_t scale of the channel.
    pub sigma_t_scale: f64,
    /// Its constant albedo (None: an albedo grid, the same in every channel).
    pub albedo: Option<f64>,
    /// Each light's irradiance or power in this channel.
    pub light_strength: Vec<f64>,
    /// The earlier channel whose images were scaled into this one (None: computed).
    pub copied_from: Option<String>,
    /// The factor of that copy (1 for equal channels; None: computed).
    pub copy_scale: Option<f64>,
    /// The earlier channel whose optical depth to the lights this channel reused (same σ_t).
    pub light_depth_from: Option<String>,
    /// Mean pixel value of the channel.
    pub mean_radiance: f64,
    /// The earlier channels (same σ_t) whose solutions started this channel's solve
    /// iteration (their residual-minimising combination; empty: started from zero).
    pub solve_started_from: Vec<String>,
    /// The channel's solver statistics (None when copied or without a solve).
    pub solver: Option<SolverReport>,
    /// The channel's seconds per stage (None when copied).
    pub seconds: Option<Timings>,
}
