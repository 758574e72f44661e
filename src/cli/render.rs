//! `pn render`: its arguments.

use clap::Args;
use pn_drivers::render::{RenderOptions, RenderRequest};
use pn_render::scene::{RenderMethod, RendererKind};
use pn_render::{DensityFilter, SceneOverride};
use pn_runtime::memory_estimate;
use std::path::PathBuf;

use super::Env;

/// Arguments of `pn render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// A scene file (.toml) or a built-in scene: cloud, nebula, sphere, lowalbedo.
    pub scene: String,
    /// Multiple scattering: pn, cda, fld, pop (Principal-Ordinates Propagation, directional
    /// and point lights), or none (single scattering only).
    #[arg(long)]
    pub method: Option<RenderMethod>,
    /// P_N order (--method pn); the highest SH band POP hands to the renderer (--method pop).
    #[arg(long, allow_negative_numbers = true)]
    pub order: Option<usize>,
    /// --method pop: cells along the longest axis of each light-aligned grid, and per side
    /// of a point light's octahedral map, 1..=512 (default: the scene's [solve]
    /// pop_resolution, else 20).
    #[arg(long, allow_negative_numbers = true)]
    pub pop_resolution: Option<usize>,
    /// --method pop: propagation iterations, ≥ 1 (default: the scene's [solve]
    /// pop_iterations, else 20).
    #[arg(long, allow_negative_numbers = true)]
    pub pop_iterations: Option<usize>,
    /// --method pop: the isotropic residuum (the paper's §5.4): after m′ iterations (Eq. 10)
    /// the lobes are made isotropic and propagated until --pop-epsilon-l of the injected
    /// power is left in flight; --pop-iterations is then not used.
    #[arg(long)]
    pub pop_residuum: bool,
    /// --method pop --pop-residuum: ε_a of Eq. 10, in (0, 1) (default 0.1).
    #[arg(long)]
    pub pop_epsilon_a: Option<f64>,
    /// --method pop --pop-residuum: stop when this fraction of the injected power is still in
    /// flight, in (0, 1) (default 1e-3).
    #[arg(long)]
    pub pop_epsilon_l: Option<f64>,
    /// Transport sweeps after the solve: source iterations of the transport equation started
    /// from the solution, which correct its error at the medium's vacuum boundary (default:
    /// the scene's [solve] sweeps, else 2; 0 renders the solution as solved; not for pop).
    #[arg(long, allow_negative_numbers = true)]
    pub sweeps: Option<usize>,
    /// The renderer: deterministic (default; noise-free ray marching) or montecarlo (delta
    /// tracking, --spp samples per pixel).
    #[arg(long)]
    pub renderer: Option<RendererKind>,
    /// Deterministic renderer: camera rays per pixel, a square number k² (a k×k pattern;
    /// default 4).
    #[arg(long, allow_negative_numbers = true)]
    pub rays: Option<usize>,
    /// Deterministic renderer: step in units of the smallest voxel side (default 0.5; the
    /// quadrature error falls like step²).
    #[arg(long, allow_negative_numbers = true)]
    pub step: Option<f64>,
    /// Deterministic renderer: trace the transmittance to the lights exactly at every step
    /// instead of interpolating the light-depth grid (slower; removes the grid's error).
    #[arg(long)]
    pub exact_transmittance: bool,
    /// Samples per pixel of the Monte Carlo renderer.
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<usize>,
    /// How density voxels are read: trilinear (Mitsuba's default) or nearest; overrides the
    /// scene's [medium] filter.
    #[arg(long)]
    pub filter: Option<DensityFilter>,
    /// Render K views from one solve: view k is the scene camera's position rotated by
    /// 2πk/K about the axis through the camera target parallel to its up vector,
    /// right-handed about up (view 0 = the scene camera); writes view_000.exr/png, ….
    #[arg(long, value_name = "K", allow_negative_numbers = true)]
    pub turntable: Option<usize>,
    /// Solve-grid cells across the medium box: one number for all axes or NX,NY,NZ.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub solve_res: Option<Vec<usize>>,
    /// Output directory (default out/render-<scene>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true, value_parser = super::parse_threads)]
    pub threads: Option<usize>,
    /// Print the unknowns with and without cropping and at the density resolution.
    #[arg(long)]
    pub stats: bool,
    /// Also write the solution: `moments.npy`, float64 of shape (nx, ny, nz, (N+1)²) at the
    /// solve-cell centres (last axis l(l+1)+m), with its grid in report.json's `unknowns`.
    #[arg(long)]
    pub save_moments: bool,
    /// Refuse solves and optical-depth grids whose estimated memory exceeds this (bytes, or
    /// with K/M/G/T; default: most of the physical memory).
    #[arg(long, value_parser = memory_estimate::parse_size)]
    pub max_memory: Option<u64>,
    /// Override any key of the scene's TOML before it is checked (repeatable, applied in
    /// order, before the other flags): `--set solve.margin=8 --set solve.absorber=box
    /// --set camera.position=[0,0,3] --set light.0.irradiance=2` (the first [[light]]). The
    /// value is read as TOML, a bare word as a string; missing tables are created; an unknown
    /// key is an error. Recorded in report.json ("overrides").
    #[arg(
        long = "set",
        value_name = "SECTION.KEY=VALUE",
        allow_hyphen_values = true
    )]
    pub set: Vec<SceneOverride>,
    /// Solve the linear PDE system in this text file for the multiple scattering instead of
    /// --method (docs/pde-text.md; e.g. pdes/sp3.pde); first-scatter source up to the highest band Q_l^m the PDE reads, the
    /// PDE's radiance moments handed to the renderer.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["method", "order"])]
    pub pde: Option<std::path::PathBuf>,
    /// Override a `param` of the --pde file (repeatable), e.g. --pde-param sigma_f=2.
    #[arg(long, value_name = "NAME=VALUE", value_parser = pn_drivers::pde_text::parse_param, requires = "pde")]
    pub pde_param: Vec<(String, String)>,
    /// --distributed and its settings (the render's linear solves over MPI processes).
    #[command(flatten)]
    pub dist: super::solve::DistributedFlags,
}

impl RenderArgs {
    /// The driver's request.
    pub fn request(&self, env: &Env) -> RenderRequest {
        RenderRequest {
            scene: self.scene.clone(),
            method: self.method,
            order: self.order,
            pop_resolution: self.pop_resolution,
            pop_iterations: self.pop_iterations,
            pop_residuum: self.pop_residuum,
            pop_epsilon_a: self.pop_epsilon_a,
            pop_epsilon_l: self.pop_epsilon_l,
            sweeps: self.sweeps,
            spp: self.spp,
            renderer: self.renderer,
            rays: self.rays,
            step: self.step,
            exact_transmittance: self.exact_transmittance,
            filter: self.filter,
            turntable: self.turntable,
            solve_res: self.solve_res.clone(),
            out: self.out.clone(),
            stats: self.stats,
            save_moments: self.save_moments,
            set: self.set.clone(),
            options: RenderOptions {
                threads: self.threads,
                max_memory: self.max_memory,
                progress: true,
                tuning: env.tuning.clone(),
                ..Default::default()
            },
            pde: self.pde.clone(),
            pde_params: self.pde_param.clone(),
            distributed: self.dist.request(),
        }
    }
}
