//! Render scenes (`pn render`): the TOML format, its validation and the built-in scenes
//! (`scenes/<name>.toml`, listed with their descriptions in [`pn_runtime::scene_registry`], which
//! also says how this format differs from the solve-scene format of [`crate::scene_file`]).
//!
//! ```toml
//! [medium]
//! kind = "cloud"            # "grid" (file = "x.vol" | "x.npy" | "x.vdb"), "sphere", "box", "cloud", "nebula"
//! grid = "density"         # "grid" with a .vdb file: the float grid to read (default: the
//!                          # grid called density, or the file's only grid)
//! seed = 7                  # procedural kinds: deterministic from the seed
//! resolution = [64, 64, 64] # density-grid resolution of procedural kinds
//! bbox_min = [-1.0, -1.0, -1.0]
//! bbox_max = [1.0, 1.0, 1.0]   # "grid": the .vol header's or the VDB transform's box unless given
//! sigma_t_scale = 20.0      # σ_t(x) = sigma_t_scale · density(x)  (1/length)
//! albedo = 0.9              # or albedo_file = "a.npy" (same grid) or "a.vdb" (with
//!                          # albedo_grid = "albedo"; read over the density's voxels)
//! filter = "trilinear"      # how voxels are read: "trilinear" (default, Mitsuba's) | "nearest"
//! [phase]
//! kind = "hg"               # "isotropic" | "hg"
//! g = 0.3
//! [[light]]
//! kind = "directional"      # travel direction (from the light into the medium)
//! direction = [0.0, -1.0, -0.3]
//! irradiance = 1.0
//! [[light]]
//! kind = "point"
//! position = [2.0, 2.0, 0.0]
//! power = 50.0              # radiant intensity power/(4π)
//! [camera]
//! position = [0.0, 0.0, 4.0]
//! target = [0.0, 0.0, 0.0]
//! up = [0.0, 1.0, 0.0]
//! fov = 40.0                # horizontal, degrees
//! width = 128
//! height = 128
//! [solve]
//! method = "pn"             # "pn" | "cda" | "fld" | "pop" | "none" (single scattering only)
//! order = 3                 # P_N order; for "pop" the highest SH band handed to the renderer
//! pop_resolution = 20       # "pop": cells along the longest axis of each light-aligned grid
//! pop_iterations = 20       # "pop": propagation iterations (without the residuum)
//! pop_residuum = false      # "pop": the isotropic residuum of the paper's §5.4
//! pop_epsilon_a = 0.1       # "pop" residuum: anisotropy threshold of the switch (Eq. 10)
//! pop_epsilon_l = 1e-3      # "pop" residuum: stop when this fraction is still in flight
//! resolution = [32, 32, 32] # solve grid over the medium box (may be coarser)
//! margin = 0                # empty cells kept around the cropped medium
//! absorber_width = 0.1667   # the absorber's ramp: this fraction of the solve cells across
//!                           # the medium box (1/6: 2 cells at 12³, 4 at 24³, 8 at 48³)
//! absorbing_layer = 2       # optional: the ramp in cells instead, at every resolution (0 = none)
//! absorber = "hull"         # where it starts: "hull" (outside the medium's convex hull,
//!                           # default) | "box" (only the outermost cells, beyond the margin)
//! boundary = "dirichlet"    # the grid's faces: "dirichlet" (zero, default) | "marshak"
//!                           # (vacuum; odd P_N only; meant for margin = absorbing_layer = 0)
//! tolerance = 1e-3         # DEFAULT_RENDER_TOLERANCE
//! sigma_t_min = 0.0         # 0 or absent: automatic where vacuum is present
//! fld_solver = "picard"     # "fld": "picard" (default) | "gs" (nonlinear Gauss–Seidel)
//! sweeps = 2                # transport sweeps after the solve (0 = none; not for "pop")
//! sweep_quadrature = 8      # the sweeps' directions: n Gauss nodes in cos θ × 2n in φ
//! [render]
//! renderer = "deterministic" # or "montecarlo"
//! rays = 4                  # deterministic: camera rays per pixel, k² (a k×k pattern)
//! step = 0.5                # deterministic: step in voxel sides (error O(step²))
//! cutoff = 1e-4             # deterministic: stop a ray when its transmittance is below
//! exact_transmittance = false # deterministic: trace T to the lights at every step
//! ms_lookup = "trilinear"   # the solution between solve-cell centres: "trilinear" | "nearest"
//! spp = 64                  # montecarlo: samples per pixel
//! seed = 1                  # montecarlo: seed of the per-pixel random streams
//! ```
//!
//! Unknown keys are refused; parse errors carry the line and column; relative file paths
//! are resolved against the scene file's folder. `pn render --set SECTION.KEY=VALUE`
//! overrides ([`super::scene_override`]) are applied to the TOML table before these checks
//! ([`RenderScene::load_with_overrides`]). See [`super::medium`] and
//! [`super::camera`] for the geometric conventions shared with the Mitsuba export.

use super::camera::{norm, Camera};
use super::colour::{Colours, GreyOrRgb};
use super::lights::Light;
use super::medium::{check_box, DensityFilter, DensityGrid, Procedural};
use super::scene_override::SceneOverride;
use anyhow::{bail, ensure, Context};
use pn_formats::npy::read_npy;
use pn_formats::vdb::{read_vdb, IndexBox, VdbGrid};
use pn_formats::vol::read_vol;
use pn_runtime::problem::Phase;
use pn_runtime::scene_registry::{self, SceneKind};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where the density comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum MediumSource {
    /// A built-in procedural medium, generated at [`MediumSpec::resolution`].
    Procedural(Procedural),
    /// A grid read from a `.vol`, `.npy` or `.vdb` file (already loaded and checked).
    File {
        /// The file (resolved against the scene's folder).
        path: PathBuf,
        /// Its contents on the medium box.
        grid: Arc<DensityGrid>,
    },
}

/// The single-scattering albedo.
#[derive(Clone, Debug, PartialEq)]
pub enum Albedo {
    /// The same everywhere.
    Constant(f64),
    /// One value per density voxel (same order as [`DensityGrid::data`]).
    Voxels(Arc<Vec<f32>>),
}

/// The participating medium.
#[derive(Clone, Debug, PartialEq)]
pub struct MediumSpec {
    /// Density source.
    pub source: MediumSource,
    /// Seed of procedural media.
    pub seed: u64,
    /// Density-grid resolution.
    pub resolution: [usize; 3],
    /// Lower corner of the medium box.
    pub bbox_min: [f64; 3],
    /// Upper corner of the medium box.
    pub bbox_max: [f64; 3],
    /// σ_t = `sigma_t_scale` × density (1/length).
    pub sigma_t_scale: f64,
    /// Albedo σ_s/σ_t.
    pub albedo: Albedo,
    /// How the density (and an albedo grid) is read between voxel centres
    /// (`[medium] filter`, default trilinear as Mitsuba; see [`super::medium`]).
    pub filter: DensityFilter,
}

impl MediumSpec {
    /// Albedo of density voxel `index`.
    #[inline]
    pub fn albedo_at(&self, index: usize) -> f64 {
        match &self.albedo {
            Albedo::Constant(a) => *a,
            Albedo::Voxels(v) => v[index] as f64,
        }
    }

    /// Albedo at the point `p`, read like the density: an albedo grid with `density`'s
    /// filter (trilinear or nearest, on the same voxels; the clamped value in the outer half
    /// voxel, 0 outside the box), a constant albedo everywhere. `density` must be this
    /// medium's grid ([`RenderScene::density_grid`]).
    ///
    /// As in Mitsuba's `heterogeneous` medium, σ_s(x) = albedo(x)·σ_t(x) with **both**
    /// filtered: between voxel centres σ_s is the product of two trilinear fields, not the
    /// interpolation of the per-voxel σ_s.
    pub fn albedo_at_point(&self, density: &DensityGrid, p: [f64; 3]) -> f64 {
        match &self.albedo {
            Albedo::Constant(a) => *a,
            Albedo::Voxels(v) => density.sample(v, p),
        }
    }

    /// σ_t(p) and σ_s(p) = albedo(p)·σ_t(p), both filtered ([`Self::albedo_at_point`]).
    pub fn coefficients_at(&self, density: &DensityGrid, p: [f64; 3]) -> (f64, f64) {
        let st = self.sigma_t_scale * density.density_at(p);
        if st == 0.0 {
            return (0.0, 0.0);
        }
        (st, st * self.albedo_at_point(density, p))
    }

    /// Kind name as in the scene file ("grid" for files).
    pub fn kind_name(&self) -> &'static str {
        match &self.source {
            MediumSource::Procedural(p) => p.name(),
            MediumSource::File { .. } => "grid",
        }
    }
}

/// The multiple-scattering method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RenderMethod {
    /// The P_N equations of the solve order.
    Pn,
    /// Classical diffusion.
    Cda,
    /// Flux-limited diffusion.
    Fld,
    /// Principal-Ordinates Propagation, directional lights (issue 20; [`crate::pop`]).
    Pop,
    /// Single scattering only.
    None,
}

impl std::str::FromStr for RenderMethod {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        match s {
            "pn" => Ok(Self::Pn),
            "cda" => Ok(Self::Cda),
            "fld" => Ok(Self::Fld),
            "pop" => Ok(Self::Pop),
            "none" => Ok(Self::None),
            _ => bail!("unknown method {s:?} (expected pn, cda, fld, pop or none)"),
        }
    }
}

impl RenderMethod {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pn => "pn",
            Self::Cda => "cda",
            Self::Fld => "fld",
            Self::Pop => "pop",
            Self::None => "none",
        }
    }
}

/// `[solve]`.
#[derive(Clone, Debug, PartialEq)]
pub struct SolveSettings {
    /// Method.
    pub method: RenderMethod,
    /// P_N order.
    pub order: usize,
    /// Solve-grid cells per axis over the medium box (before cropping).
    pub resolution: [usize; 3],
    /// Empty solve cells kept around the cropped medium.
    pub margin: usize,
    /// Width of the graded absorber's ramp as a fraction of the solve grid's cells across the
    /// medium box ([`Self::ramp_cells`]): a width fixed in space, so that the absorber is
    /// resolved as the grid is refined ([`DEFAULT_ABSORBER_WIDTH`]).
    pub absorber_width: f64,
    /// The ramp in cells, the same at every resolution, instead of [`Self::absorber_width`]
    /// (0: no absorber; the Dirichlet boundary then sits right at the margin). Such a ramp
    /// does not converge as h → 0 (docs/vacuum.md); kept for studies and tight crops.
    pub absorbing_layer: Option<usize>,
    /// Where the graded absorber starts ([`AbsorberPlacement`]).
    pub absorber: AbsorberPlacement,
    /// The condition on the solve grid's faces ([`SolveBoundary`]).
    pub boundary: SolveBoundary,
    /// Relative residual tolerance of the solver.
    pub tolerance: f64,
    /// σ_t threshold; `None` = automatic where vacuum is present.
    pub sigma_t_min: Option<f64>,
    /// Method fld: how the nonlinear system is solved.
    pub fld_solver: FldSolver,
    /// Method pop: cells along the longest axis of each light-aligned grid.
    pub pop_resolution: usize,
    /// Method pop: propagation iterations (without the residuum).
    pub pop_iterations: usize,
    /// Method pop: the isotropic residuum (§5.4) instead of a fixed iteration count.
    pub pop_residuum: bool,
    /// Method pop, residuum: ε_a, the anisotropy below which lobes count as isotropic.
    pub pop_epsilon_a: f64,
    /// Method pop, residuum: ε_L, the fraction of the injected power still in flight at
    /// which the isotropic iteration stops.
    pub pop_epsilon_l: f64,
    /// Transport sweeps after the solve ([`super::transport_sweep`]; methods pn, cda, fld
    /// and text PDEs; 0: the solution as solved). [`DEFAULT_SWEEPS`].
    pub sweeps: usize,
    /// Gauss–Legendre nodes in μ of the sweeps' directions (`n × 2n` directions,
    /// [`DEFAULT_SWEEP_QUADRATURE`]).
    pub sweep_quadrature: usize,
}

/// Default number of transport sweeps after a render's solve (`[solve] sweeps`). Each is one
/// source iteration of the transport equation started from the solution, which removes most
/// of what P_N gets wrong at the medium's vacuum boundary: on the five scenes of issue 17's
/// study at 24³ the P_5 bias against Mitsuba went from −4.9…−0.2 % to −0.1…+1.0 % with two
/// sweeps (P_3: −10.0…+3.8 % to −2.3…+2.6 %), for 6–18 % of the solve's time
/// (docs/vacuum.md, "Transport sweeps").
pub const DEFAULT_SWEEPS: usize = 2;

/// Default Gauss–Legendre nodes in μ of the sweeps' angular rule (`[solve]
/// sweep_quadrature`): 8 × 16 = 128 directions, exact for the moments up to l = 7; on the
/// cloud at P_3 @ 24³ the image moves by 0.08 % of its mean (0.3 % RMS) from 8 to 16 nodes.
pub const DEFAULT_SWEEP_QUADRATURE: usize = 8;

/// Most transport sweeps a scene may ask for.
pub const MAX_SWEEPS: usize = 100;

/// Default relative residual of a render's solve (`[solve] tolerance`). The image needs far
/// less than the solver can give: on the cloud (P_7 @ 32³), the cumulus and the nebula
/// (P_5 @ 32³), the puff (P_3 @ 16³), and the cloud with FLD and CDA, 1e-3 instead of 1e-6
/// changes the image mean by at most 1e-5 of itself, its relative RMS by at most 6e-5 and no
/// pixel by more than 5e-4 of the mean — three orders of magnitude below the P_N error
/// against Mitsuba — while the P_N solves take 45–50 % fewer iterations (docs/rendering.md,
/// "The solver tolerance of a render"). Tests and studies that need tighter solves set it.
pub const DEFAULT_RENDER_TOLERANCE: f64 = 1e-3;

/// Default POP grid resolution (the paper's typical 20³, §7).
pub const POP_DEFAULT_RESOLUTION: usize = 20;
/// Default POP iterations (about the grid resolution along the light, the paper's §7).
pub const POP_DEFAULT_ITERATIONS: usize = 20;
/// Default ε_a of POP's isotropic residuum (the paper's "around 0.1", §5.4).
pub const POP_DEFAULT_EPSILON_A: f64 = 0.1;
/// Default ε_L of POP's isotropic residuum (relative to the injected power).
pub const POP_DEFAULT_EPSILON_L: f64 = 1e-3;
/// Largest POP grid resolution.
pub const POP_MAX_RESOLUTION: usize = 512;
/// Most POP iterations.
pub const POP_MAX_ITERATIONS: usize = 100_000;

/// Where the solve grid's vacuum becomes a graded pure absorber (`[solve] absorber`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AbsorberPlacement {
    /// Outside the medium's convex hull, graded over [`SolveSettings::ramp_cells`], where light
    /// cannot return ([`super::hull_absorber`]); plus the outer layer of `Box`. The default.
    #[default]
    Hull,
    /// Only the outermost [`SolveSettings::layer_cells`] of the solve grid, beyond the margin
    /// ([`super::solve_setup::add_absorbing_layer`]; the treatment before issue 17).
    Box,
}

/// How a render solves the nonlinear FLD system (`[solve] fld_solver`; docs/fld.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FldSolver {
    /// Picard steps, each a multigrid-preconditioned CG solve of the linear diffusion
    /// equation with D frozen (the default: 2.5–8× faster than `Gs` on the race scenes, the
    /// same answer; docs/fld.md).
    #[default]
    Picard,
    /// Red–black nonlinear Gauss–Seidel/SOR sweeps (the FLD paper's solver).
    Gs,
}

/// The condition on the solve grid's faces (`[solve] boundary`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SolveBoundary {
    /// Zero moments on the faces; with the graded absorber in front of them this is where
    /// the escaping light ends (the default).
    #[default]
    Dirichlet,
    /// Marshak's vacuum condition on every face (docs/design.md §3): the half-range moments
    /// of the incoming radiance vanish. Staggered P_N of odd order only. Meant for a grid
    /// cropped tightly to the medium (`margin = 0`, `absorbing_layer = 0`), where the
    /// medium touches the faces (issue 17's Marshak arm).
    Marshak,
}

/// Which renderer draws the image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RendererKind {
    /// Ray marching with a fixed pattern of camera rays: noise-free
    /// ([`super::march`]; the default).
    #[default]
    Deterministic,
    /// Delta tracking with next-event estimation, `spp` random samples per pixel
    /// ([`super::renderer`]).
    MonteCarlo,
}

impl std::str::FromStr for RendererKind {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        match s {
            "deterministic" => Ok(Self::Deterministic),
            "montecarlo" => Ok(Self::MonteCarlo),
            _ => bail!("unknown renderer {s:?} (expected deterministic or montecarlo)"),
        }
    }
}

impl RendererKind {
    /// Lower-case name, as in the scene file and `--renderer`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Deterministic => "deterministic",
            Self::MonteCarlo => "montecarlo",
        }
    }
}

/// `[render]`.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// The renderer.
    pub renderer: RendererKind,
    /// Samples per pixel (Monte Carlo renderer).
    pub spp: usize,
    /// Seed of the per-pixel random streams (Monte Carlo renderer).
    pub seed: u64,
    /// Camera rays per pixel of the deterministic renderer: a square number k² (k×k
    /// stratified sub-pixel positions).
    pub rays: usize,
    /// Step of the deterministic renderer in units of the smallest voxel side.
    pub step: f64,
    /// The deterministic renderer stops a ray when its transmittance falls below this.
    pub cutoff: f64,
    /// The deterministic renderer traces the transmittance to the lights exactly at every
    /// step instead of interpolating the light-depth grid (slower; no grid error).
    pub exact_transmittance: bool,
    /// How both renderers read the multiple-scattering solution between solve-cell centres.
    pub ms_lookup: MsLookup,
}

/// How the renderers read the un-staggered solution L_l^m between solve-cell centres
/// (`[render] ms_lookup`; issue 17's lookup arm). Both converge to the same image as the
/// solve grid is refined; they differ by O(h) where the solution has a boundary layer
/// thinner than a cell (the first mean free path below the medium's surface).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MsLookup {
    /// Trilinear between the cell centres, clamped at the grid's outer centres (the default).
    #[default]
    Trilinear,
    /// The value of the solve cell that contains the point (piecewise constant).
    Nearest,
}

/// Default camera rays per pixel of the deterministic renderer (2×2).
pub const DEFAULT_RAYS: usize = 4;
/// Default step of the deterministic renderer (voxel sides).
pub const DEFAULT_STEP: f64 = 0.5;
/// Default transmittance cutoff of the deterministic renderer.
pub const DEFAULT_CUTOFF: f64 = 1e-4;
/// Most camera rays per pixel (16×16).
pub const MAX_RAYS: usize = 256;
/// Accepted steps (voxel sides): smaller ones cost time without visible gain, larger ones
/// skip voxels.
pub const STEP_RANGE: (f64, f64) = (1e-3, 4.0);

/// A complete render scene.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderScene {
    /// Name (file stem or built-in name).
    pub name: String,
    /// Medium.
    pub medium: MediumSpec,
    /// Phase function.
    pub phase: Phase,
    /// Lights.
    pub lights: Vec<Light>,
    /// Per-channel values of a coloured scene (`None`: grey). A coloured scene's grey fields
    /// (`medium.sigma_t_scale`, a constant `medium.albedo`, the lights' strengths) hold the
    /// mean of the channels; it is rendered channel by channel ([`RenderScene::channel`]).
    pub colours: Option<Colours>,
    /// Camera.
    pub camera: Camera,
    /// Solve settings.
    pub solve: SolveSettings,
    /// Render settings.
    pub render: RenderSettings,
}

/// Names of the built-in render scenes (the [`SceneKind::Render`] entries of
/// [`pn_runtime::scene_registry::BUILTIN_SCENES`]).
pub fn builtin_names() -> Vec<&'static str> {
    scene_registry::names(SceneKind::Render)
}

/// Largest samples per pixel accepted.
pub const MAX_SPP: usize = 1 << 20;

// ---- TOML representation ----

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SceneToml {
    medium: MediumToml,
    phase: Option<PhaseToml>,
    #[serde(default)]
    light: Vec<LightToml>,
    camera: CameraToml,
    solve: Option<SolveToml>,
    render: Option<RenderToml>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MediumToml {
    kind: String,
    file: Option<PathBuf>,
    grid: Option<String>,
    seed: Option<u64>,
    resolution: Option<[usize; 3]>,
    bbox_min: Option<[f64; 3]>,
    bbox_max: Option<[f64; 3]>,
    sigma_t_scale: GreyOrRgb,
    albedo: Option<GreyOrRgb>,
    albedo_file: Option<PathBuf>,
    albedo_grid: Option<String>,
    filter: Option<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct PhaseToml {
    kind: String,
    g: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct LightToml {
    kind: String,
    direction: Option<[f64; 3]>,
    irradiance: Option<GreyOrRgb>,
    position: Option<[f64; 3]>,
    power: Option<GreyOrRgb>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct CameraToml {
    position: [f64; 3],
    target: [f64; 3],
    up: [f64; 3],
    fov: f64,
    width: usize,
    height: usize,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SolveToml {
    method: Option<RenderMethod>,
    order: Option<usize>,
    resolution: Option<[usize; 3]>,
    margin: Option<usize>,
    absorbing_layer: Option<usize>,
    absorber_width: Option<f64>,
    absorber: Option<AbsorberPlacement>,
    boundary: Option<SolveBoundary>,
    tolerance: Option<f64>,
    sigma_t_min: Option<f64>,
    fld_solver: Option<FldSolver>,
    pop_resolution: Option<usize>,
    pop_iterations: Option<usize>,
    pop_residuum: Option<bool>,
    pop_epsilon_a: Option<f64>,
    pop_epsilon_l: Option<f64>,
    sweeps: Option<usize>,
    sweep_quadrature: Option<usize>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RenderToml {
    renderer: Option<RendererKind>,
    spp: Option<usize>,
    seed: Option<u64>,
    rays: Option<usize>,
    step: Option<f64>,
    cutoff: Option<f64>,
    exact_transmittance: Option<bool>,
    ms_lookup: Option<MsLookup>,
}

const DEFAULT_BBOX: ([f64; 3], [f64; 3]) = ([-1.0; 3], [1.0; 3]);

impl RenderScene {
    /// The grey scene of channel `c` (0 = R, 1 = G, 2 = B): this scene with the channel's
    /// σ_t scale, albedo and light strengths ([`Colours`]); a grey scene is its own channel.
    pub fn channel(&self, c: usize) -> RenderScene {
        let mut s = self.clone();
        if let Some(col) = s.colours.take() {
            s.medium.sigma_t_scale = col.sigma_t_scale[c];
            if let Some(a) = col.albedo {
                s.medium.albedo = Albedo::Constant(a[c]);
            }
            for (light, strength) in s.lights.iter_mut().zip(&col.light_strength) {
                *light = light.with_strength(strength[c]);
            }
        }
        s
    }

    /// Replaces the medium's density, and optionally its albedo, by arrays held in memory
    /// (the Python package): `density` and `albedo` in C order of shape `dims` = (nx, ny, nz),
    /// x the slowest axis, as `.npy` files are read; they cover the scene's medium box. The
    /// checks are those of grid files: finite, non-negative densities, albedos in [0, 1].
    pub fn set_density_arrays(
        &mut self,
        dims: [usize; 3],
        density: Vec<f64>,
        albedo: Option<Vec<f64>>,
    ) -> anyhow::Result<()> {
        let (bmin, bmax) = (self.medium.bbox_min, self.medium.bbox_max);
        let vg = pn_runtime::field::VoxelGrid::new(dims, bmin, bmax, density).context("density")?;
        let grid = DensityGrid::from_voxel_grid(&vg, bmin, bmax).context("density")?;
        if let Some(a) = albedo {
            ensure!(
                self.colours.as_ref().is_none_or(|c| c.albedo.is_none()),
                "give the albedo per channel or as an array, not both"
            );
            let va = pn_runtime::field::VoxelGrid::new(dims, bmin, bmax, a).context("albedo")?;
            self.medium.albedo = albedo_voxels(&va, bmin, bmax).context("albedo")?;
        }
        self.medium.resolution = grid.res;
        self.medium.source = MediumSource::File {
            path: PathBuf::from("<array>"),
            grid: Arc::new(grid),
        };
        Ok(())
    }

    /// Reads and checks a scene file (errors name the file, and the line and column for
    /// syntax and type errors).
    pub fn from_path(path: &Path) -> anyhow::Result<RenderScene> {
        Self::from_path_with_overrides(path, &[])
    }

    /// [`RenderScene::from_path`] with `--set` overrides applied to the file's TOML before it
    /// is checked ([`RenderScene::from_toml_str_with_overrides`]). The name is the file stem.
    pub fn from_path_with_overrides(
        path: &Path,
        overrides: &[SceneOverride],
    ) -> anyhow::Result<RenderScene> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read scene file {}", path.display()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut scene =
            Self::from_toml_str_with_overrides(&text, base, overrides).with_context(|| {
                match crate::scene_kind::toml_kind(&text) {
                    Some(SceneKind::Solve) => format!(
                        "scene file {} ({})",
                        path.display(),
                        scene_registry::wrong_kind_file_hint(path, SceneKind::Solve)
                    ),
                    _ => format!("scene file {}", path.display()),
                }
            })?;
        if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
            scene.name = stem.to_string();
        }
        Ok(scene)
    }

    /// Parses and checks a scene from TOML text; relative paths are resolved against
    /// `base_dir`. The name is "scene" (see [`RenderScene::from_path`]).
    pub fn from_toml_str(s: &str, base_dir: &Path) -> anyhow::Result<RenderScene> {
        Self::from_toml_str_with_overrides(s, base_dir, &[])
    }

    /// [`RenderScene::from_toml_str`] with `--set` overrides: the text must be a valid scene
    /// on its own (its errors keep their line and column); then each override is applied to
    /// its TOML table in order ([`SceneOverride::apply`]) and the result is read and checked
    /// as if it had been written in the file. An unknown key or a wrong type is refused with
    /// the field's name and the `--set` that introduced it; a value the checks refuse gets the
    /// overrides as context.
    pub fn from_toml_str_with_overrides(
        s: &str,
        base_dir: &Path,
        overrides: &[SceneOverride],
    ) -> anyhow::Result<RenderScene> {
        // toml's Display names the line and column and quotes the offending line.
        let t: SceneToml = toml::from_str(s).map_err(|e| anyhow::anyhow!("{e}"))?;
        if overrides.is_empty() {
            return build(t, base_dir);
        }
        let pristine: toml::Table = toml::from_str(s).map_err(|e| anyhow::anyhow!("{e}"))?;
        let all = || {
            overrides
                .iter()
                .map(|o| o.text.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let read = |table: &toml::Table| -> Result<SceneToml, String> {
            toml::Value::Table(table.clone())
                .try_into::<SceneToml>()
                .map_err(|e| e.message().trim_end().to_string())
        };
        let mut table = pristine.clone();
        for o in overrides {
            o.apply(&mut table)?;
        }
        let t = match read(&table) {
            Ok(t) => t,
            Err(e) => {
                // Name the override that gives this very error on its own, if one does.
                for o in overrides {
                    let mut one = pristine.clone();
                    o.apply(&mut one)?;
                    if read(&one).err().as_deref() == Some(e.as_str()) {
                        bail!("--set {o}: {e}");
                    }
                }
                bail!("--set {}: {e}", all())
            }
        };
        build(t, base_dir).with_context(|| format!("with --set {}", all()))
    }

    /// A built-in render scene ([`builtin_names`]; the same files as `scenes/<name>.toml`,
    /// compiled in by [`pn_runtime::scene_registry`]). `None` for any other name, a built-in
    /// solve scene's included.
    pub fn builtin(name: &str) -> Option<RenderScene> {
        let text = scene_registry::find_kind(name, SceneKind::Render)?.toml?;
        // The built-in files are tested to parse (see the tests below).
        let mut s = Self::from_toml_str(text, Path::new(".")).ok()?;
        s.name = name.to_string();
        Some(s)
    }

    /// A built-in name or a scene file path. A built-in solve scene's name (`checkerboard`,
    /// …) is refused with a message naming `pn solve`.
    pub fn load(arg: &str) -> anyhow::Result<RenderScene> {
        Self::load_with_overrides(arg, &[])
    }

    /// [`RenderScene::load`] with `--set` overrides applied to the scene's TOML (a file's or
    /// a built-in's text) before it is checked
    /// ([`RenderScene::from_toml_str_with_overrides`]). The name stays the file stem or the
    /// built-in name.
    pub fn load_with_overrides(
        arg: &str,
        overrides: &[SceneOverride],
    ) -> anyhow::Result<RenderScene> {
        let path = Path::new(arg);
        if arg.ends_with(".toml") || path.is_file() {
            return Self::from_path_with_overrides(path, overrides);
        }
        if let Some(e) = scene_registry::wrong_kind_error(arg, SceneKind::Render) {
            return Err(e);
        }
        let unknown = || {
            format!(
                "{arg:?} is neither a scene file nor a built-in scene ({})",
                builtin_names().join(", ")
            )
        };
        if overrides.is_empty() {
            return Self::builtin(arg).with_context(unknown);
        }
        let text = scene_registry::find_kind(arg, SceneKind::Render)
            .and_then(|e| e.toml)
            .with_context(unknown)?;
        let mut s = Self::from_toml_str_with_overrides(text, Path::new("."), overrides)
            .with_context(|| format!("built-in scene {arg}"))?;
        s.name = arg.to_string();
        Ok(s)
    }

    /// The density grid of the medium (generated for procedural media), read with the
    /// medium's [`MediumSpec::filter`].
    pub fn density_grid(&self) -> anyhow::Result<DensityGrid> {
        let m = &self.medium;
        let g = match &m.source {
            MediumSource::Procedural(p) => p.grid(m.resolution, m.bbox_min, m.bbox_max, m.seed)?,
            MediumSource::File { grid, .. } => (**grid).clone(),
        };
        Ok(g.with_filter(m.filter))
    }
}

fn finite3(name: &str, v: [f64; 3]) -> anyhow::Result<()> {
    ensure!(
        v.iter().all(|c| c.is_finite()),
        "{name} must be finite, got {v:?}"
    );
    Ok(())
}

fn nonneg(name: &str, v: f64) -> anyhow::Result<()> {
    ensure!(
        v.is_finite() && v >= 0.0,
        "{name} must be finite and non-negative, got {v}"
    );
    Ok(())
}

/// What a grid file holds: its voxels, whether the file placed them in space, and for a VDB
/// file the grid itself with the index box read (to read a second grid over the same voxels).
struct GridFile {
    voxels: pn_runtime::field::VoxelGrid,
    placed: bool,
    vdb: Option<(VdbGrid, IndexBox)>,
}

/// Reads a `.vol`, `.npy` or `.vdb` grid file; `grid` names the grid of a VDB file.
fn read_grid_file(path: &Path, grid: Option<&str>) -> anyhow::Result<GridFile> {
    let ext = path.extension().and_then(|e| e.to_str());
    ensure!(
        grid.is_none() || ext == Some("vdb"),
        "{}: a grid name applies to .vdb files only",
        path.display()
    );
    match ext {
        Some("vol") => Ok(GridFile {
            voxels: read_vol(path)?,
            placed: true,
            vdb: None,
        }),
        Some("npy") => {
            let a = read_npy(path)?;
            ensure!(
                a.shape.len() == 3,
                "{}: expected a 3D array of shape (nx, ny, nz), got shape {:?}",
                path.display(),
                a.shape
            );
            let dims = [a.shape[0], a.shape[1], a.shape[2]];
            let (min, max) = DEFAULT_BBOX;
            Ok(GridFile {
                voxels: pn_runtime::field::VoxelGrid::new(dims, min, max, a.data)?,
                placed: false,
                vdb: None,
            })
        }
        Some("vdb") => {
            let g = read_vdb(path, grid)?;
            let window = g.active_box.with_context(|| {
                format!("{}: grid {:?} has no active voxels", path.display(), g.name)
            })?;
            let voxels = g
                .dense(window)
                .with_context(|| format!("VDB file {}", path.display()))?;
            Ok(GridFile {
                voxels,
                placed: true,
                vdb: Some((g, window)),
            })
        }
        _ => bail!(
            "{}: unsupported grid file (expected .vol, .npy or .vdb)",
            path.display()
        ),
    }
}

/// A per-voxel albedo on the density's voxels (the box of the medium): finite, non-negative
/// (the density grid's checks) and at most 1.
fn albedo_voxels(
    vg: &pn_runtime::field::VoxelGrid,
    bbox_min: [f64; 3],
    bbox_max: [f64; 3],
) -> anyhow::Result<Albedo> {
    let g = DensityGrid::from_voxel_grid(vg, bbox_min, bbox_max)?;
    if let Some(p) = g.data.iter().position(|v| *v > 1.0) {
        bail!("value {} at index {p} exceeds 1", g.data[p]);
    }
    Ok(Albedo::Voxels(Arc::new(g.data)))
}

/// Reads the albedo grid file. A VDB albedo next to a VDB density is read over the density's
/// index box (its inactive voxels read as 0) and must share the density's transform, so that
/// the two grids' voxels coincide; otherwise the file's voxels are taken as they are.
fn read_albedo_file(
    path: &Path,
    grid: Option<&str>,
    density: Option<&(VdbGrid, IndexBox)>,
) -> anyhow::Result<pn_runtime::field::VoxelGrid> {
    match density {
        Some((d, window)) if path.extension().and_then(|e| e.to_str()) == Some("vdb") => {
            let a = read_vdb(path, grid)?;
            ensure!(
                a.transform == d.transform,
                "{}: grid {:?} has the index-to-world map {:?}, the density grid {:?} has {:?}; \
                 the two grids must share one transform",
                path.display(),
                a.name,
                a.transform,
                d.name,
                d.transform
            );
            a.dense(*window)
                .with_context(|| format!("VDB file {}", path.display()))
        }
        _ => Ok(read_grid_file(path, grid)?.voxels),
    }
}

fn build_medium(m: MediumToml, base: &Path) -> anyhow::Result<MediumSpec> {
    for v in m.sigma_t_scale.channels() {
        nonneg("medium.sigma_t_scale", v)?;
    }
    for (n, v) in [
        ("medium.bbox_min", m.bbox_min),
        ("medium.bbox_max", m.bbox_max),
    ] {
        if let Some(v) = v {
            finite3(n, v)?;
        }
    }
    let seed = m.seed.unwrap_or(0);
    let mut density_vdb = None;
    let (source, resolution, bbox_min, bbox_max) = match m.kind.as_str() {
        "grid" => {
            let file = m
                .file
                .context("medium.kind = \"grid\" needs medium.file (a .vol, .npy or .vdb file)")?;
            ensure!(
                m.seed.is_none(),
                "medium.seed applies to procedural media only"
            );
            let path = base.join(&file);
            let gf = read_grid_file(&path, m.grid.as_deref()).context("medium.file")?;
            density_vdb = gf.vdb;
            let (vg, has_box) = (gf.voxels, gf.placed);
            if let Some(r) = m.resolution {
                ensure!(
                    r == vg.dims,
                    "medium.resolution {r:?} disagrees with the grid file's {:?}; leave it out",
                    vg.dims
                );
            }
            let (dmin, dmax) = if has_box {
                (vg.min, vg.max)
            } else {
                DEFAULT_BBOX
            };
            let bmin = m.bbox_min.unwrap_or(dmin);
            let bmax = m.bbox_max.unwrap_or(dmax);
            let grid = DensityGrid::from_voxel_grid(&vg, bmin, bmax)
                .with_context(|| format!("density file {}", path.display()))?;
            let res = grid.res;
            (
                MediumSource::File {
                    path,
                    grid: Arc::new(grid),
                },
                res,
                bmin,
                bmax,
            )
        }
        other => {
            let p = match other {
                "sphere" => Procedural::Sphere,
                "box" => Procedural::Box,
                "cloud" => Procedural::Cloud,
                "nebula" => Procedural::Nebula,
                _ => bail!(
                    "unknown medium.kind {other:?} (expected grid, sphere, box, cloud or nebula)"
                ),
            };
            ensure!(
                m.file.is_none() && m.grid.is_none(),
                "medium.file and medium.grid apply to kind = \"grid\" only"
            );
            let res = m.resolution.unwrap_or([64; 3]);
            ensure!(
                res.iter().all(|&n| n > 0),
                "medium.resolution must be positive on every axis, got {res:?}"
            );
            (
                MediumSource::Procedural(p),
                res,
                m.bbox_min.unwrap_or(DEFAULT_BBOX.0),
                m.bbox_max.unwrap_or(DEFAULT_BBOX.1),
            )
        }
    };
    check_box(bbox_min, bbox_max).context("medium")?;
    let filter = match &m.filter {
        None => DensityFilter::default(),
        Some(f) => f.parse::<DensityFilter>().context("medium.filter")?,
    };
    ensure!(
        m.albedo_grid.is_none() || m.albedo_file.is_some(),
        "medium.albedo_grid needs medium.albedo_file (a .vdb file)"
    );
    let albedo = match (m.albedo, m.albedo_file) {
        (Some(_), Some(_)) => bail!("give medium.albedo or medium.albedo_file, not both"),
        (None, None) => bail!("medium.albedo (or medium.albedo_file) is required"),
        (Some(a), None) => {
            for a in a.channels() {
                ensure!(
                    a.is_finite() && (0.0..=1.0).contains(&a),
                    "medium.albedo must lie in [0, 1], got {a}"
                );
            }
            Albedo::Constant(channel_mean(a))
        }
        (None, Some(f)) => {
            let path = base.join(&f);
            let vg = read_albedo_file(&path, m.albedo_grid.as_deref(), density_vdb.as_ref())
                .context("medium.albedo_file")?;
            ensure!(
                vg.dims == resolution,
                "albedo file {} has resolution {:?}, the density grid {:?}",
                path.display(),
                vg.dims,
                resolution
            );
            albedo_voxels(&vg, bbox_min, bbox_max)
                .with_context(|| format!("albedo file {}", path.display()))?
        }
    };
    Ok(MediumSpec {
        source,
        seed,
        resolution,
        bbox_min,
        bbox_max,
        sigma_t_scale: channel_mean(m.sigma_t_scale),
        albedo,
        filter,
    })
}

/// The grey value of a per-channel value: the mean of its channels (a coloured scene's grey
/// fields hold these; it is rendered channel by channel, [`RenderScene::channel`]).
fn channel_mean(v: GreyOrRgb) -> f64 {
    match v {
        GreyOrRgb::Grey(x) => x,
        GreyOrRgb::Rgb(c) => (c[0] + c[1] + c[2]) / 3.0,
    }
}

/// A light and its strength (irradiance or power) as given, grey or per channel.
fn build_light(l: LightToml, n: usize) -> anyhow::Result<(Light, GreyOrRgb)> {
    let ctx = || format!("light {} (kind = {:?})", n + 1, l.kind);
    match l.kind.as_str() {
        "directional" => {
            ensure!(
                l.position.is_none() && l.power.is_none(),
                "{}: position and power apply to point lights",
                ctx()
            );
            let d = l
                .direction
                .with_context(|| format!("{}: needs direction", ctx()))?;
            let e = l
                .irradiance
                .with_context(|| format!("{}: needs irradiance", ctx()))?;
            finite3("direction", d).with_context(ctx)?;
            let len = norm(d);
            ensure!(len > 0.0, "{}: direction must not be zero", ctx());
            for v in e.channels() {
                nonneg("irradiance", v).with_context(ctx)?;
            }
            let light = Light::Directional {
                direction: d.map(|c| c / len),
                irradiance: channel_mean(e),
            };
            Ok((light, e))
        }
        "point" => {
            ensure!(
                l.direction.is_none() && l.irradiance.is_none(),
                "{}: direction and irradiance apply to directional lights",
                ctx()
            );
            let p = l
                .position
                .with_context(|| format!("{}: needs position", ctx()))?;
            let w = l.power.with_context(|| format!("{}: needs power", ctx()))?;
            finite3("position", p).with_context(ctx)?;
            for v in w.channels() {
                nonneg("power", v).with_context(ctx)?;
            }
            let light = Light::Point {
                position: p,
                power: channel_mean(w),
            };
            Ok((light, w))
        }
        k => bail!(
            "light {}: unknown kind {k:?} (expected directional or point)",
            n + 1
        ),
    }
}

fn build(t: SceneToml, base: &Path) -> anyhow::Result<RenderScene> {
    let (sigma_t_scale, albedo) = (t.medium.sigma_t_scale, t.medium.albedo);
    let medium = build_medium(t.medium, base).context("[medium]")?;
    let phase = match t.phase {
        None => Phase::Isotropic,
        Some(p) => match p.kind.as_str() {
            "isotropic" => {
                ensure!(p.g.is_none(), "[phase]: g applies to kind = \"hg\" only");
                Phase::Isotropic
            }
            "hg" => {
                let g = p.g.context("[phase]: kind = \"hg\" needs g")?;
                ensure!(
                    g.is_finite() && g.abs() < 1.0,
                    "[phase]: Henyey–Greenstein g must satisfy |g| < 1, got {g}"
                );
                Phase::HenyeyGreenstein(g)
            }
            k => bail!("[phase]: unknown kind {k:?} (expected isotropic or hg)"),
        },
    };
    let (lights, strengths): (Vec<Light>, Vec<GreyOrRgb>) = t
        .light
        .into_iter()
        .enumerate()
        .map(|(n, l)| build_light(l, n))
        .collect::<anyhow::Result<Vec<_>>>()?
        .into_iter()
        .unzip();
    let coloured = sigma_t_scale.is_rgb()
        || albedo.is_some_and(|a| a.is_rgb())
        || strengths.iter().any(|s| s.is_rgb());
    let colours = coloured.then(|| Colours {
        sigma_t_scale: sigma_t_scale.channels(),
        albedo: albedo.map(|a| a.channels()),
        light_strength: strengths.iter().map(|s| s.channels()).collect(),
    });
    let c = t.camera;
    let camera = Camera {
        position: c.position,
        target: c.target,
        up: c.up,
        fov_deg: c.fov,
        width: c.width,
        height: c.height,
    };
    camera.validate().context("[camera]")?;
    let s = t.solve.unwrap_or(SolveToml {
        method: None,
        order: None,
        resolution: None,
        margin: None,
        absorbing_layer: None,
        absorber_width: None,
        absorber: None,
        boundary: None,
        tolerance: None,
        sigma_t_min: None,
        fld_solver: None,
        pop_resolution: None,
        pop_iterations: None,
        pop_residuum: None,
        pop_epsilon_a: None,
        pop_epsilon_l: None,
        sweeps: None,
        sweep_quadrature: None,
    });
    let solve = SolveSettings {
        method: s.method.unwrap_or(RenderMethod::Pn),
        order: s.order.unwrap_or(3),
        resolution: s.resolution.unwrap_or([32; 3]),
        margin: s.margin.unwrap_or(DEFAULT_MARGIN),
        absorber_width: s.absorber_width.unwrap_or(DEFAULT_ABSORBER_WIDTH),
        absorbing_layer: s.absorbing_layer,
        absorber: s.absorber.unwrap_or_default(),
        boundary: s.boundary.unwrap_or_default(),
        tolerance: s.tolerance.unwrap_or(DEFAULT_RENDER_TOLERANCE),
        sigma_t_min: s.sigma_t_min.filter(|v| *v != 0.0),
        fld_solver: s.fld_solver.unwrap_or_default(),
        pop_resolution: s.pop_resolution.unwrap_or(POP_DEFAULT_RESOLUTION),
        pop_iterations: s.pop_iterations.unwrap_or(POP_DEFAULT_ITERATIONS),
        pop_residuum: s.pop_residuum.unwrap_or(false),
        pop_epsilon_a: s.pop_epsilon_a.unwrap_or(POP_DEFAULT_EPSILON_A),
        pop_epsilon_l: s.pop_epsilon_l.unwrap_or(POP_DEFAULT_EPSILON_L),
        sweeps: s.sweeps.unwrap_or(DEFAULT_SWEEPS),
        sweep_quadrature: s.sweep_quadrature.unwrap_or(DEFAULT_SWEEP_QUADRATURE),
    };
    solve.validate().context("[solve]")?;
    let r = t.render.unwrap_or(RenderToml {
        renderer: None,
        spp: None,
        seed: None,
        rays: None,
        step: None,
        cutoff: None,
        exact_transmittance: None,
        ms_lookup: None,
    });
    let render = RenderSettings {
        renderer: r.renderer.unwrap_or_default(),
        spp: r.spp.unwrap_or(64),
        seed: r.seed.unwrap_or(1),
        rays: r.rays.unwrap_or(DEFAULT_RAYS),
        step: r.step.unwrap_or(DEFAULT_STEP),
        cutoff: r.cutoff.unwrap_or(DEFAULT_CUTOFF),
        exact_transmittance: r.exact_transmittance.unwrap_or(false),
        ms_lookup: r.ms_lookup.unwrap_or_default(),
    };
    render.validate().context("[render]")?;
    Ok(RenderScene {
        name: "scene".into(),
        medium,
        phase,
        lights,
        colours,
        camera,
        solve,
        render,
    })
}

/// Default width of the absorber's ramp, as a fraction of the solve cells across the medium
/// box ([`SolveSettings::absorber_width`]): 2 cells at 12³, 4 at 24³, 8 at 48³. A ramp fixed
/// in cells reflects the same share of the light at every h and N, so the image stops
/// converging (docs/vacuum.md, "The absorber must shrink in space, not in cells"); one fixed
/// in space is resolved as h → 0 and converges, to transport as N → ∞ as well. At a given
/// grid a wider ramp reflects less (a 2-cell ramp 0.125 of the amplitude, a 4-cell one 0.058,
/// `scripts/absorber-reflection.py`): the former 1/12 left the cumulus' +2 % offset of
/// issue 17, which 1/6 removes (docs/vacuum.md, "Transport sweeps"). With the empty margin
/// gone ([`DEFAULT_MARGIN`]) the solve grid at 24³ has as many cells as with 1/12 and a
/// 2-cell margin.
pub const DEFAULT_ABSORBER_WIDTH: f64 = 1.0 / 6.0;

/// Default empty margin around the cropped medium (`[solve] margin`), in cells. The hull
/// absorber starts at the medium's convex hull, so the cells of a margin only lengthen the
/// absorber's full-strength tail; they change no image (0.00 pp on five scenes,
/// docs/vacuum.md) and cost unknowns.
pub const DEFAULT_MARGIN: usize = 0;

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
        ensure!(
            (1..=64).contains(&self.sweep_quadrature),
            "sweep_quadrature must lie in 1..=64 (Gauss nodes in cos θ), got {}",
            self.sweep_quadrature
        );
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
    /// step (in [`STEP_RANGE`]) and the cutoff (in [0, 1)).
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
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[medium]
kind = "sphere"
resolution = [8, 8, 8]
sigma_t_scale = 2.0
albedo = 0.5
[[light]]
kind = "directional"
direction = [0.0, -2.0, 0.0]
irradiance = 1.0
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 8
height = 8
"#;

    fn parse(s: &str) -> anyhow::Result<RenderScene> {
        RenderScene::from_toml_str(s, Path::new("."))
    }

    fn err(s: &str) -> String {
        format!("{:#}", parse(s).unwrap_err())
    }

    #[test]
    fn builtin_scenes_parse() {
        for name in builtin_names() {
            let s = RenderScene::builtin(name).unwrap_or_else(|| panic!("{name}"));
            assert_eq!(s.name, name);
            let g = s.density_grid().unwrap();
            assert!(g.max_density() > 0.0, "{name}");
        }
        assert!(RenderScene::builtin("nope").is_none());
        assert!(RenderScene::builtin("checkerboard").is_none());
        let e = format!("{:#}", RenderScene::load("checkerboard").unwrap_err());
        assert!(
            e.contains("`pn solve checkerboard`") && e.contains("built-in"),
            "{e}"
        );
        let e = format!("{:#}", RenderScene::load("nope").unwrap_err());
        assert!(e.contains("built-in") && e.contains("lowalbedo"), "{e}");
    }

    #[test]
    fn defaults_and_normalisation() {
        let s = parse(MINIMAL).unwrap();
        assert_eq!(s.phase, Phase::Isotropic);
        assert_eq!(
            s.lights[0],
            Light::Directional {
                direction: [0.0, -1.0, 0.0],
                irradiance: 1.0
            }
        );
        assert_eq!(s.solve.method, RenderMethod::Pn);
        assert_eq!(s.solve.sigma_t_min, None);
        assert_eq!(s.render.spp, 64);
    }

    #[test]
    fn bad_input_is_refused_with_the_field() {
        let e = err(&MINIMAL.replace("albedo = 0.5", "albedo = 0.5\ncolour = 1"));
        assert!(e.contains("unknown field") && e.contains("line"), "{e}");
        let e = err(&MINIMAL.replace("albedo = 0.5", "albedo = 1.5"));
        assert!(e.contains("[0, 1]"), "{e}");
        let e = err(&MINIMAL.replace("sigma_t_scale = 2.0", "sigma_t_scale = -2.0"));
        assert!(e.contains("non-negative"), "{e}");
        let e = err(&MINIMAL.replace("sigma_t_scale = 2.0", "sigma_t_scale = nan"));
        assert!(e.contains("sigma_t_scale"), "{e}");
        let e = err(&MINIMAL.replace("width = 8", "width = 0"));
        assert!(e.contains("image size"), "{e}");
        let e = err(&MINIMAL.replace("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, 1.0]"));
        assert!(e.contains("parallel"), "{e}");
        let e = err(&MINIMAL.replace("fov = 40.0", "fov = 180.0"));
        assert!(e.contains("fov"), "{e}");
        let e = err(&MINIMAL.replace("kind = \"sphere\"", "kind = \"torus\""));
        assert!(e.contains("torus"), "{e}");
        let e = err(&MINIMAL.replace("irradiance = 1.0", "irradiance = -1.0"));
        assert!(e.contains("irradiance"), "{e}");
        let e = err(&MINIMAL.replace("fov = 40.0", "fov = \"wide\""));
        assert!(e.contains("line 15, column 7"), "{e}");
    }

    fn with_sets(sets: &[&str]) -> anyhow::Result<RenderScene> {
        let o: Vec<SceneOverride> = sets.iter().map(|s| s.parse().unwrap()).collect();
        RenderScene::from_toml_str_with_overrides(MINIMAL, Path::new("."), &o)
    }

    #[test]
    fn set_overrides_apply_before_the_checks() {
        let s = with_sets(&[
            "solve.margin=8",
            "solve.sigma_t_min=0.5",
            "solve.absorber=box",
            "camera.position=[0,0,3]",
            "light.0.irradiance=2",
            "render.exact_transmittance=true",
            "phase.kind=hg",
            "phase.g=0.3",
        ])
        .unwrap();
        assert_eq!(s.solve.margin, 8);
        assert_eq!(s.solve.sigma_t_min, Some(0.5));
        assert_eq!(s.solve.absorber, AbsorberPlacement::Box);
        assert_eq!(s.camera.position, [0.0, 0.0, 3.0]);
        assert_eq!(
            s.lights[0],
            Light::Directional {
                direction: [0.0, -1.0, 0.0],
                irradiance: 2.0
            }
        );
        assert!(s.render.exact_transmittance);
        assert_eq!(s.phase, Phase::HenyeyGreenstein(0.3));
        // The file alone is unchanged by an empty list.
        assert_eq!(with_sets(&[]).unwrap(), parse(MINIMAL).unwrap());
        // A built-in keeps its name.
        let o: SceneOverride = "solve.margin=5".parse().unwrap();
        let b = RenderScene::load_with_overrides("sphere", &[o]).unwrap();
        assert_eq!((b.name.as_str(), b.solve.margin), ("sphere", 5));
    }

    #[test]
    fn bad_set_overrides_name_the_key_and_the_flag() {
        let e = format!(
            "{:#}",
            with_sets(&["solve.margin=8", "solve.nonsense=1"]).unwrap_err()
        );
        assert!(
            e.contains("--set solve.nonsense=1") && e.contains("unknown field `nonsense`"),
            "{e}"
        );
        assert!(!e.contains("solve.margin=8"), "{e}");
        let e = format!("{:#}", with_sets(&["colour.x=1"]).unwrap_err());
        assert!(
            e.contains("--set colour.x=1") && e.contains("`colour`"),
            "{e}"
        );
        let e = format!("{:#}", with_sets(&["solve.margin=wide"]).unwrap_err());
        assert!(
            e.contains("--set solve.margin=wide") && e.contains("wide"),
            "{e}"
        );
        let e = format!("{:#}", with_sets(&["solve.margin=100"]).unwrap_err());
        assert!(
            e.contains("with --set solve.margin=100") && e.contains("at most 64"),
            "{e}"
        );
        let e = format!("{:#}", with_sets(&["light.3.irradiance=1"]).unwrap_err());
        assert!(e.contains("out of range"), "{e}");
        let o: SceneOverride = "solve.nonsense=1".parse().unwrap();
        let e = format!(
            "{:#}",
            RenderScene::load_with_overrides("sphere", &[o]).unwrap_err()
        );
        assert!(
            e.contains("built-in scene sphere") && e.contains("nonsense"),
            "{e}"
        );
    }

    #[test]
    fn the_density_filter_is_read_and_applied() {
        let s = parse(MINIMAL).unwrap();
        assert_eq!(s.medium.filter, DensityFilter::Trilinear);
        assert_eq!(s.density_grid().unwrap().filter, DensityFilter::Trilinear);
        let s =
            parse(&MINIMAL.replace("albedo = 0.5", "albedo = 0.5\nfilter = \"nearest\"")).unwrap();
        assert_eq!(s.medium.filter, DensityFilter::Nearest);
        assert_eq!(s.density_grid().unwrap().filter, DensityFilter::Nearest);
        let e = err(&MINIMAL.replace("albedo = 0.5", "albedo = 0.5\nfilter = \"cubic\""));
        assert!(
            e.contains("medium.filter") && e.contains("\"cubic\"") && e.contains("trilinear"),
            "{e}"
        );
    }

    #[test]
    fn render_settings_have_defaults_and_are_checked() {
        let s = parse(MINIMAL).unwrap();
        assert_eq!(s.render.renderer, RendererKind::Deterministic);
        assert_eq!((s.render.rays, s.render.step), (DEFAULT_RAYS, DEFAULT_STEP));
        let with = |r: &str| format!("{MINIMAL}[render]\n{r}\n");
        let s = parse(&with("renderer = \"montecarlo\"\nrays = 9\nstep = 0.25")).unwrap();
        assert_eq!(s.render.renderer, RendererKind::MonteCarlo);
        assert_eq!((s.render.rays, s.render.step), (9, 0.25));
        for (bad, want) in [
            ("rays = 3", "square number"),
            ("rays = 0", "square number"),
            ("rays = 1024", "square number"),
            ("step = 0.0", "step must lie"),
            ("step = 10.0", "step must lie"),
            ("step = nan", "step must lie"),
            ("cutoff = 1.0", "cutoff"),
            ("cutoff = -0.1", "cutoff"),
            ("renderer = \"magic\"", "unknown variant"),
        ] {
            let e = err(&with(bad));
            assert!(e.contains(want), "{bad}: {e}");
        }
    }

    #[test]
    fn the_grid_boundary_is_read_and_marshak_needs_odd_pn() {
        assert_eq!(
            parse(MINIMAL).unwrap().solve.boundary,
            SolveBoundary::Dirichlet
        );
        let with = |r: &str| format!("{MINIMAL}[solve]\n{r}\n");
        let s = parse(&with(
            "boundary = \"marshak\"\nmargin = 0\nabsorbing_layer = 0",
        ))
        .unwrap();
        assert_eq!(s.solve.boundary, SolveBoundary::Marshak);
        for (bad, want) in [
            ("boundary = \"marshak\"\norder = 4", "odd order"),
            ("boundary = \"marshak\"\nmethod = \"cda\"", "odd order"),
            ("boundary = \"robin\"", "unknown variant"),
        ] {
            let e = err(&with(bad));
            assert!(e.contains(want), "{bad}: {e}");
        }
    }

    /// The default ramp keeps its size in space: 2 cells at 12³, 4 at 24³, 8 at 48³ (the
    /// padding rounds it up); `absorbing_layer` fixes it in cells instead.
    #[test]
    fn the_absorber_ramp_is_fixed_in_space_unless_given_in_cells() {
        let with = |r: &str| format!("{MINIMAL}[solve]\n{r}\n");
        for (res, cells) in [(12, 2.0), (24, 4.0), (48, 8.0), (32, 32.0 / 6.0)] {
            let s = parse(&with(&format!("resolution = [{res}, {res}, {res}]"))).unwrap();
            assert!((s.solve.ramp_cells() - cells).abs() < 1e-12, "{res}");
            assert_eq!(s.solve.padding(), s.solve.margin + cells.ceil() as usize);
        }
        let s = parse(&with("resolution = [48, 24, 24]\nabsorber_width = 0.25")).unwrap();
        assert_eq!(s.solve.ramp_cells(), 12.0);
        let s = parse(&with("resolution = [48, 48, 48]\nabsorbing_layer = 3")).unwrap();
        assert_eq!((s.solve.ramp_cells(), s.solve.layer_cells()), (3.0, 3));
        for (bad, want) in [
            ("absorber_width = -0.1", "absorber_width must lie in [0, 1]"),
            ("absorber_width = nan", "absorber_width must lie in [0, 1]"),
            ("absorbing_layer = 65", "at most 64 cells"),
            (
                "resolution = [512, 512, 512]\nabsorber_width = 0.5",
                "at most 64 cells",
            ),
        ] {
            let e = err(&with(bad));
            assert!(e.contains(want), "{bad}: {e}");
        }
    }

    #[test]
    fn a_solve_scene_file_points_to_pn_solve() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/box.toml");
        let e = format!("{:#}", RenderScene::from_path(&path).unwrap_err());
        assert!(
            e.contains("this is a solve scene file: run it with `pn solve "),
            "{e}"
        );
        assert!(e.contains("unknown field"), "{e}");
    }

    #[test]
    fn vol_files_are_read_and_bad_ones_refused() {
        let dir = std::env::temp_dir().join(format!("pn-render-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let g = DensityGrid::new([2, 1, 1], [0.0; 3], [2.0, 1.0, 1.0], vec![0.25, 1.0]).unwrap();
        let bytes = pn_formats::vol::encode_vol(&g.to_voxel_grid());
        std::fs::write(dir.join("d.vol"), &bytes).unwrap();
        std::fs::write(dir.join("bad.vol"), &bytes[..bytes.len() - 2]).unwrap();
        let text = MINIMAL
            .replace("kind = \"sphere\"", "kind = \"grid\"\nfile = \"d.vol\"")
            .replace("resolution = [8, 8, 8]\n", "");
        let s = RenderScene::from_toml_str(&text, &dir).unwrap();
        assert_eq!(s.density_grid().unwrap(), g);
        let e = format!(
            "{:#}",
            RenderScene::from_toml_str(&text.replace("d.vol", "bad.vol"), &dir).unwrap_err()
        );
        assert!(e.contains("bytes of data"), "{e}");
        // A per-voxel albedo from .npy (shape (nx, ny, nz), x first) on the same grid.
        pn_formats::npy::write_npy(&dir.join("a.npy"), &[2, 1, 1], &[0.5, 0.25]).unwrap();
        let with_albedo = text.replace("albedo = 0.5", "albedo_file = \"a.npy\"");
        let s = RenderScene::from_toml_str(&with_albedo, &dir).unwrap();
        assert_eq!((s.medium.albedo_at(0), s.medium.albedo_at(1)), (0.5, 0.25));
        pn_formats::npy::write_npy(&dir.join("b.npy"), &[2, 1, 1], &[0.5, 1.5]).unwrap();
        let e = format!(
            "{:#}",
            RenderScene::from_toml_str(&with_albedo.replace("a.npy", "b.npy"), &dir).unwrap_err()
        );
        assert!(e.contains("exceeds 1"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn vdb_files_are_read_with_their_placement_and_grid_names() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/vdb");
        let text = MINIMAL
            .replace(
                "kind = \"sphere\"",
                "kind = \"grid\"\nfile = \"offset12.vdb\"",
            )
            .replace("resolution = [8, 8, 8]\n", "");
        let s = RenderScene::from_toml_str(&text, &data).unwrap();
        let g = s.density_grid().unwrap();
        // The box of tests/data/vdb/offset12.json (OpenVDB's indexToWorld of the outer corners).
        assert_eq!(g.res, [12, 12, 12]);
        assert_eq!(
            (s.medium.bbox_min, s.medium.bbox_max),
            ([-0.1875, -0.6875, 1.3125], [1.3125, 0.8125, 2.8125])
        );
        // The same voxels through a .vol file give the same medium.
        let dir = std::env::temp_dir().join(format!("pn-render-vdb-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let vg = pn_formats::vdb::read_vdb(&data.join("offset12.vdb"), None)
            .unwrap()
            .dense_active()
            .unwrap();
        std::fs::write(dir.join("same.vol"), pn_formats::vol::encode_vol(&vg)).unwrap();
        let vol =
            RenderScene::from_toml_str(&text.replace("offset12.vdb", "same.vol"), &dir).unwrap();
        assert_eq!(vol.density_grid().unwrap(), g);
        std::fs::remove_dir_all(&dir).unwrap();

        // A named grid, and an albedo grid of the same file read over the density's voxels:
        // 0.9 on 8³ of the 12³ cells, inactive (0) elsewhere.
        let two = text.replace("offset12.vdb", "two_grids.vdb").replace(
            "albedo = 0.5",
            "albedo_file = \"two_grids.vdb\"\nalbedo_grid = \"albedo\"",
        );
        let e = format!("{:#}", RenderScene::from_toml_str(&two, &data).unwrap_err());
        assert!(e.contains("say which one with the `grid` key"), "{e}");
        let named = two.replace(
            "\nfile = \"two_grids.vdb\"\n",
            "\nfile = \"two_grids.vdb\"\ngrid = \"smoke\"\n",
        );
        let s = RenderScene::from_toml_str(&named, &data).unwrap();
        let albedo: Vec<f64> = (0..12 * 12 * 12).map(|i| s.medium.albedo_at(i)).collect();
        assert_eq!(albedo.iter().filter(|&&a| a == 0.9f32 as f64).count(), 512);
        assert_eq!(
            albedo.iter().filter(|&&a| a == 0.0).count(),
            12 * 12 * 12 - 512
        );

        for (scene, want) in [
            // An albedo grid whose voxels are not the density's.
            (
                text.replace("albedo = 0.5", "albedo_file = \"cloud16.vdb\""),
                "share one transform",
            ),
            (
                text.replace("albedo = 0.5", "albedo = 0.5\nalbedo_grid = \"a\""),
                "albedo_grid needs medium.albedo_file",
            ),
            (
                text.replace("file = \"offset12.vdb\"", "file = \"half16.vdb\""),
                "half precision",
            ),
            (
                text.replace(
                    "file = \"offset12.vdb\"",
                    "file = \"offset12.vdb\"\ngrid = \"heat\"",
                ),
                "no grid named \"heat\"",
            ),
            (
                text.replace("file = \"offset12.vdb\"", "file = \"offset12.json\""),
                "expected .vol, .npy or .vdb",
            ),
        ] {
            let e = format!(
                "{:#}",
                RenderScene::from_toml_str(&scene, &data).unwrap_err()
            );
            assert!(e.contains(want), "want {want:?}: {e}");
        }
        let e = err(&MINIMAL.replace("kind = \"sphere\"", "kind = \"sphere\"\ngrid = \"density\""));
        assert!(e.contains("apply to kind = \"grid\" only"), "{e}");
    }
}
