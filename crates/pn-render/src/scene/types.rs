//! The render scene's types: the medium, the solve and render settings, the scene itself,
//! their defaults and limits.

use crate::camera::Camera;
use crate::colour::Colours;
use crate::lights::Light;
use crate::medium::{DensityFilter, DensityGrid, Procedural};
use crate::sky::{Sky, SkyLights};
use anyhow::bail;
use pn_runtime::problem::Phase;
use serde::Deserialize;
use std::path::PathBuf;
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
    /// (`[medium] filter`, default trilinear as Mitsuba; see [`crate::medium`]).
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
    /// Principal-Ordinates Propagation, directional and point lights (issues 20, 52;
    /// [`crate::pop`]).
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
    /// Method pop, point lights: radial shells of each radial grid (`None`: cells about as
    /// long as wide, docs/pop-design.md "Point lights").
    pub pop_shells: Option<usize>,
    /// Method pop: how the propagated result is resampled onto the solve grid.
    pub pop_upsample: PopUpsample,
    /// Method pop, `pop_upsample = "bilateral"`: the range kernel's width relative to the
    /// largest σ_s at the POP cell centres.
    pub pop_upsample_sigma: f64,
    /// Transport sweeps after the solve ([`crate::transport_sweep`]; methods pn, cda, fld
    /// and text PDEs; 0: the solution as solved). [`DEFAULT_SWEEPS`].
    pub sweeps: usize,
    /// Gauss–Legendre nodes in μ of the sweeps' directions (`n × 2n` directions); `None`:
    /// [`SolveSettings::sweep_nodes`]'s default, which grows with the order.
    pub sweep_quadrature: Option<usize>,
    /// Each sweep followed by a correction solved with the method's own operator (P_N, CDA:
    /// synthetic acceleration, [`crate::transport_sweep`]; `[solve] sweep_acceleration`):
    /// the sweeps then reach the transport solution they converge to in far fewer steps.
    pub sweep_acceleration: bool,
    /// The sweeps' spatial scheme (`[solve] sweep_scheme`, [`SweepScheme`]).
    pub sweep_scheme: SweepScheme,
    /// The scattering order L the sweeps carry when it is above the method's own (P_N and
    /// CDA with sweeps; `[solve] sweep_order`): delta-M at order L, the first-scatter source
    /// to band L, the solution padded with zeros above its bands, and the sweeps scattering
    /// with the phase's factors l ≤ L. With `sweep_acceleration` the method's operator is
    /// then the low-order correction of an S_N transport solve (CDA: diffusion synthetic
    /// acceleration). None: the method's order.
    pub sweep_order: Option<usize>,
    /// Delta-M truncation of the phase for the solve ([`crate::delta_m`]; methods pn, cda
    /// and fld; default on): the forward peak f = λ_{N+1} p_{N+1} travels on as unscattered
    /// light, the camera's single scattering stays exact. The identity for isotropic media.
    pub delta_m: bool,
    /// The similarity relation instead of delta-M's order-N truncation (`[solve] similarity`;
    /// default off): the share f = g = λ_1 p_1 travels on unscattered and the solve carries
    /// σ_s (1 − g) with an isotropic phase, whatever the solve's order. An ablation arm: unlike
    /// delta-M (f = λ_{N+1} p_{N+1} → 0) it does not converge to transport as N grows.
    pub similarity: bool,
    /// The band up to which the last transport sweep keeps the radiance it computed
    /// (`[solve] sweep_bands`; None: the solve's own bands), read by the camera's last
    /// scattering with the full phase ([`crate::transport_sweep::transport_sweeps_to_band`]).
    /// At most 2 × `sweep_quadrature` − 1 (what the angular rule resolves).
    pub sweep_bands: Option<usize>,
}

impl SolveSettings {
    /// The sweeps' Gauss–Legendre nodes in μ: `sweep_quadrature` where given, else
    /// max([`DEFAULT_SWEEP_QUADRATURE`], N + 1). A sweep projects the radiance it computed on
    /// the moments l ≤ N, and its in-scattering reads them: products of degree up to 2N in μ,
    /// which n Gauss nodes integrate exactly for 2n − 1 ≥ 2N. With 8 nodes at P_9 (fewer than
    /// N + 1 = 10) the g = 0.877 scene's bias against Mitsuba was −3.4 % at 24³, 36³ and 48³
    /// alike; with 10 nodes +0.03 % (docs/lab/race/2026-12-07-bias-vs-order).
    pub fn sweep_nodes(&self) -> usize {
        let order = self.order.max(self.sweep_order.unwrap_or(0));
        self.sweep_quadrature
            .unwrap_or_else(|| DEFAULT_SWEEP_QUADRATURE.max(order + 1))
    }

    /// The scattering order the sweeps carry for a method of order `own` that can extend
    /// them ([`SolveSettings::sweep_order`]): the larger of the two when there are sweeps.
    pub fn sweep_band(&self, own: usize) -> usize {
        match self.sweep_order {
            Some(l) if self.sweeps > 0 => own.max(l),
            _ => own,
        }
    }
}

/// Default number of transport sweeps after a render's solve (`[solve] sweeps`). Each is one
/// source iteration of the transport equation started from the solution, which removes most
/// of what P_N gets wrong at the medium's vacuum boundary: on the five scenes of issue 17's
/// study at 24³ the P_5 bias against Mitsuba went from −4.9…−0.2 % to −0.1…+1.0 % with two
/// sweeps (P_3: −10.0…+3.8 % to −2.3…+2.6 %), for 6–18 % of the solve's time
/// (docs/vacuum.md, "Transport sweeps").
pub const DEFAULT_SWEEPS: usize = 2;

/// Highest `[solve] sweep_order`: (L + 1)² moments per solve cell are swept and kept.
pub const MAX_SWEEP_ORDER: usize = 15;

/// Least Gauss–Legendre nodes in μ of the sweeps' angular rule (`[solve] sweep_quadrature`
/// unset; [`SolveSettings::sweep_nodes`]): 8 × 16 = 128 directions, exact for the moments up
/// to l = 7; on the cloud at P_3 @ 24³ the image moves by 0.08 % of its mean (0.3 % RMS) from
/// 8 to 16 nodes.
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
/// Most radial shells of a point light's POP grid.
pub const POP_MAX_SHELLS: usize = 512;
/// Default width of the bilateral upsampling's range kernel, relative to the largest σ_s.
pub const POP_DEFAULT_UPSAMPLE_SIGMA: f64 = 0.1;

/// How POP's coarse result is resampled onto the solve grid (`[solve] pop_upsample`;
/// docs/pop-design.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PopUpsample {
    /// Trilinear between the POP cell centres.
    #[default]
    Trilinear,
    /// The joint bilateral upsampling of the paper's §4.4, guided by σ_s.
    Bilateral,
}

/// Where the solve grid's vacuum becomes a graded pure absorber (`[solve] absorber`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AbsorberPlacement {
    /// Outside the medium's convex hull, graded over [`SolveSettings::ramp_cells`], where light
    /// cannot return ([`crate::hull_absorber`]); plus the outer layer of `Box`. The default.
    #[default]
    Hull,
    /// Only the outermost [`SolveSettings::layer_cells`] of the solve grid, beyond the margin
    /// ([`crate::solve_setup::add_absorbing_layer`]; the treatment before issue 17).
    Box,
}

/// The spatial discretization of the transport sweeps (`[solve] sweep_scheme`;
/// [`crate::transport_sweep`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SweepScheme {
    /// Upwind step with exact attenuation: positive, first order in h; its converged
    /// limit is 12–26 % bright on an optically thick cloud at 16³–32³ (no thick diffusion
    /// limit), two sweeps from P_N move part of the way there. The default (measured best
    /// of the two after two sweeps, docs/lab/race/2026-12-07-night-forward).
    #[default]
    Step,
    /// Diamond difference with the set-to-zero fixup: second order in h; its converged limit
    /// is within −1.4 … −2.6 % on the same cloud.
    Diamond,
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
    /// ([`crate::march`]; the default).
    #[default]
    Deterministic,
    /// Delta tracking with next-event estimation, `spp` random samples per pixel
    /// ([`crate::renderer`]).
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
    /// Lights are not seen directly (Mitsuba volpath's `hide_emitters`): the sky behind and
    /// around the medium is black, only the light the medium scatters is shown.
    pub hide_emitters: bool,
    /// Node spacing, in voxel sides, of the grid on which the deterministic renderer
    /// tabulates the sky's single scattering once per view (docs/sky.md); 0: every sky
    /// light at every step of every ray.
    pub sky_grid: f64,
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

/// Default `[render] sky_grid` (voxel sides between the nodes of the sky's single-scattering
/// grid; docs/sky.md measures it).
pub const DEFAULT_SKY_GRID: f64 = 1.0;

/// Largest `[render] sky_grid`.
pub const MAX_SKY_GRID: f64 = 16.0;
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
    /// The sky ([`crate::sky`]): a uniform sky or an environment map (`None`: black).
    pub sky: Option<Sky>,
    /// The sky cut into directional lights, appended to `lights` (set by
    /// [`RenderScene::with_sky_lights`]; `None` until then).
    pub sky_lights: Option<Arc<SkyLights>>,
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

/// Largest samples per pixel accepted.
pub const MAX_SPP: usize = 1 << 20;

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
            s.sky = s.sky.map(|sky| sky.channel(c));
        }
        s
    }

    /// Replaces the scene's sky (the Python package's numpy map): checks it
    /// ([`Sky::validate`]) and makes a grey scene coloured when the sky is RGB (its grey
    /// values in every channel). Refused once the sky is cut into lights.
    pub fn set_sky(&mut self, sky: Sky) -> anyhow::Result<()> {
        if self.sky_lights.is_some() {
            bail!("the sky is already cut into directional lights");
        }
        sky.validate()?;
        if sky.is_rgb() && self.colours.is_none() {
            self.colours = Some(Colours {
                sigma_t_scale: [self.medium.sigma_t_scale; 3],
                albedo: None,
                light_strength: self.lights.iter().map(|l| [l.strength(); 3]).collect(),
            });
        }
        self.sky = Some(sky);
        Ok(())
    }

    /// This scene with its sky cut into directional lights ([`crate::sky::Sky::lights`]),
    /// appended to its lights (per channel for a coloured scene), and [`Self::sky_lights`]
    /// set; a scene without a sky, or whose sky is already cut, as it is.
    pub fn with_sky_lights(&self) -> RenderScene {
        let mut s = self.clone();
        let Some(sky) = &self.sky else {
            return s;
        };
        if self.sky_lights.is_some() {
            return s;
        }
        let lights = SkyLights::new(sky, &self.phase, self.lights.len());
        for l in &lights.lights {
            s.lights.push(Light::Directional {
                direction: l.travel,
                irradiance: sky.grey(l.irradiance),
            });
            if let Some(col) = s.colours.as_mut() {
                col.light_strength.push(l.irradiance);
            }
        }
        s.sky_lights = Some(Arc::new(lights));
        s
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

/// The medium box when a scene gives none.
pub(super) const DEFAULT_BBOX: ([f64; 3], [f64; 3]) = ([-1.0; 3], [1.0; 3]);
