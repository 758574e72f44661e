//! The render pipeline: a [`RenderScene`] and plain [`RenderOptions`] in, a [`RenderRun`]
//! (images, statistics, timings, notes) out, in memory; nothing is written or printed.
//!
//! [`render_views`] builds the density grid, hands the scene to its multiple-scattering
//! method ([`methods::MultipleScattering`], chosen once by [`methods::method_for`]: P_N,
//! CDA, FLD, POP, none, or a text PDE), renders the views (the deterministic ray marcher or
//! the Monte Carlo renderer) and fills the [`RenderReport`]. A coloured scene is solved and
//! rendered per channel (the `rgb` module) and combined.

use crate::light_depth::LightDepth;
use crate::pde_kernel::PdeKernel;
use crate::renderer::{Image, MsField};
use crate::{Camera, RenderScene};
use anyhow::Result;
use pn_runtime::solver::{IterationObserver, SolverTuning};
use std::sync::Arc;

mod grey;
pub mod methods;
mod report;
mod rgb;

pub use crate::progress::ProgressCallback;
pub use report::{ChannelReport, RenderReport, SolverReport, Timings, UnknownStats, ViewReport};
pub use rgb::RgbImages;

/// How [`render_views`] runs (not what it renders).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// Refuse solves whose estimated memory exceeds this many bytes (default: 80% of the
    /// physical memory).
    pub max_memory: Option<u64>,
    /// Whether the caller wants progress displays. The library draws nothing and only passes
    /// this on: a command (pn-drivers, the Python package) turns it into an
    /// [`RenderOptions::observer`] of the solves and a [`RenderOptions::rows`] callback.
    pub progress: bool,
    /// Expert solver settings (the `pn` binary reads them from the environment).
    pub tuning: SolverTuning,
    /// A text PDE solved for the multiple scattering instead of the scene's method (the
    /// scene's method must then be `cda`; the first-scatter source up to the highest band
    /// Q_l^m the PDE reads, the radiance moments of the solution handed to the renderer).
    pub pde: Option<Arc<PdeKernel>>,
    /// Called after every iteration of the P_N / CDA / text-PDE solves (per channel of a
    /// coloured scene, counting from 1 each time); FLD's Gauss–Seidel solve is not observed.
    pub observer: Option<IterationObserver>,
    /// Called as the image rows are rendered (None: nobody watches).
    pub rows: Option<ProgressCallback>,
    /// Solves the linear systems of P_N, CDA and text PDEs instead of
    /// `pn_runtime::pipeline::solve_problem_from` (a distributed solve, say); FLD and POP
    /// keep their own solvers.
    pub linear_solver: Option<LinearSolver>,
}

/// A replacement for the render's linear solves (see [`RenderOptions::linear_solver`]):
/// given the problem, the stencil, the solver settings and the start guesses (other
/// channels' solutions), it returns the solution.
#[derive(Clone)]
pub struct LinearSolver(
    /// The solve.
    pub Arc<LinearSolveFn>,
);

/// The function behind a [`LinearSolver`]: problem, stencil, solver settings and start
/// guesses in, solution out.
pub type LinearSolveFn = dyn Fn(
        &pn_runtime::Problem,
        &dyn pn_stencil::StencilKernel,
        &pn_runtime::solver::SolverOptions,
        &[&[f64]],
    ) -> Result<pn_runtime::Solution>
    + Send
    + Sync;

impl std::fmt::Debug for LinearSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("LinearSolver(..)")
    }
}

impl PartialEq for LinearSolver {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Default for RenderOptions {
    /// All cores, the default memory limit, the solver's progress display, tuned solver
    /// defaults, nobody watching.
    fn default() -> Self {
        Self {
            threads: None,
            max_memory: None,
            progress: true,
            tuning: SolverTuning::default(),
            pde: None,
            observer: None,
            rows: None,
            linear_solver: None,
        }
    }
}

/// A finished render.
pub struct RenderRun {
    /// The image (view 0 of a turntable).
    pub image: Image,
    /// The turntable's images, view 0 first (empty for a single view).
    pub views: Vec<Image>,
    /// The channel images of a coloured scene (`None` for a grey one).
    pub rgb: Option<RgbImages>,
    /// The multiple-scattering solution on its solve grid (grey scenes with a solve).
    pub solution: Option<MsField>,
    /// The optical depth to the lights (grey scenes that computed it: a solve or the
    /// deterministic renderer).
    pub light_depth: Option<Arc<LightDepth>>,
    /// The staggered solution vector of a P_N or CDA solve (grey scenes), the start guess
    /// for another channel with the same σ_t (`pn_runtime::pipeline::solve_problem_from`).
    pub staggered: Option<Vec<f64>>,
    /// Its report.
    pub report: RenderReport,
    /// Lines for the user, in the order they arose (`warning: …`: a solve that stopped
    /// short, an empty medium, a medium out of view); the command prints them on stderr.
    pub notes: Vec<String>,
}

/// What a channel's render may take over from channels rendered before it with the same
/// σ_t (both depend on σ_t and the lights' geometry only, or serve as a start).
#[derive(Default)]
struct SharedWork<'a> {
    /// The optical depth to the lights.
    light_depth: Option<Arc<LightDepth>>,
    /// Staggered solutions on the same solve grid, to start the iteration from.
    guesses: Vec<&'a [f64]>,
}

/// Camera `k` of a `views`-view turntable around `camera`: its position rotated by
/// 2πk/`views` about the axis through the target parallel to up, right-handed about up
/// ([`Camera::orbit`]); view 0 is `camera` itself.
pub fn turntable_camera(camera: &Camera, k: usize, views: usize) -> Camera {
    if k == 0 {
        return camera.clone();
    }
    camera.orbit(2.0 * std::f64::consts::PI * k as f64 / views as f64)
}

/// Most turntable views.
pub const MAX_VIEWS: usize = 3600;

/// Solves and renders `scene` from its camera.
pub fn render_scene(scene: &RenderScene, options: &RenderOptions) -> Result<RenderRun> {
    render_views(scene, options, 1)
}

/// Solves `scene` once and renders `views` turntable views of it ([`turntable_camera`];
/// one view: the scene's camera). A coloured scene is solved and rendered per channel;
/// its [`RenderRun::image`] is then the mean of the channels.
pub fn render_views(
    scene: &RenderScene,
    options: &RenderOptions,
    views: usize,
) -> Result<RenderRun> {
    // A sky becomes directional lights here, once, for every channel and view.
    let scene = &scene.with_sky_lights();
    if scene.colours.is_some() {
        return rgb::render_views_rgb(scene, options, views);
    }
    grey::render_grey_views(scene, options, views, SharedWork::default())
}

fn mean(data: &[f32]) -> f64 {
    data.iter().map(|v| *v as f64).sum::<f64>() / data.len().max(1) as f64
}

/// Root mean square of the values.
fn rms(data: &[f32]) -> f64 {
    (data.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / data.len().max(1) as f64).sqrt()
}
