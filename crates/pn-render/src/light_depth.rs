//! The optical depth from every point of the medium to each light, precomputed on a grid
//! for the deterministic renderer ([`super::march`]).
//!
//! The nodes are the **density-voxel centres**; at each node the optical depth τ to the
//! light is the exact integral of [`Extinction::optical_depth`] (traversal of the filter's
//! lattice, [`super::shadow`]), traced only near the medium ([`LightDepth::compute`]) for
//! point lights; directional ones use planes, below. One grid serves a whole render: the
//! first-scatter source's quadrature ([`super::source_quadrature`]) and the camera rays
//! ([`super::march`]) read the same. Between the nodes τ is interpolated trilinearly (clamped
//! to the outermost centres in the outer half voxel) and the transmittance is `exp(−τ)`:
//! interpolating τ rather than T keeps the interpolant exact for a τ linear in x (a
//! homogeneous slab lit along an axis) and avoids the bias of interpolating a convex
//! function of depth (between two nodes of very different depth, interpolating T
//! overestimates e^{−τ}).
//!
//! The interpolation error is O(h²·|∂²τ|) with h the voxel size (O(h·|∇τ|) in the outer half
//! voxel, where the density of a medium with vacuum around it is 0); it does not shrink with
//! the renderer's step (see the error budget in [`super::march`]). τ is continuous
//! everywhere (also for a point light inside the medium, where it behaves like σ_t·r), so
//! the interpolant is too.
//!
//! **Directional lights: planes across the light.** Along the light τ grows by σ_t·h per
//! voxel (≈ 1 in a dense cloud) and its slope σ_t has kinks at every voxel-centre plane, so
//! interpolating τ *along* the light between voxel centres errs by up to ≈ σ_t h/4 — the
//! main error of the voxel-centre grid (measured on the built-in cloud: −0.97 % bias, 3.6 %
//! relative RMS against exact transmittance). For a directional light the grid is therefore
//! built in the light's frame ([`PlaneDepth`]): planes perpendicular to the travel direction
//! d, one smallest voxel side apart, each holding τ on a square lattice of spacing
//! `h_⊥ = `[`PLANE_SPACING`]` × smallest voxel side`, computed exactly column by column
//! (one traversal per column, [`Extinction::optical_depth_at_marks`]). A lookup at x takes the plane
//! upstream of x, interpolates τ *bilinearly in the plane only*, and adds the exact optical
//! depth of the short segment (shorter than one voxel side) from x back to that plane.
//! The only approximation left is the transverse interpolation, O(h_⊥²·|∂²_⊥τ|) where τ is
//! smooth across the light and O(h_⊥·|∇_⊥τ|) next to a shadow edge; it is measured against
//! exact transmittance in `render::march` (test `light_depth_grid_error_on_the_cloud`).
//! Point lights keep the voxel-centre grid.
//!
//! Columns stop at τ = [`TAU_CUTOFF`] (T < 10⁻¹⁷): deeper planes hold +∞ (T = 0), an
//! absolute error below 10⁻¹⁷·E.

use super::lights::Light;
use super::medium::floor_fast;
use super::medium::DensityGrid;
use super::shadow::{near_medium_mask, Extinction};
use rayon::prelude::*;

/// Largest stored optical depth: e^{−745} is the smallest positive f64, so deeper is black
/// (and a transmittance of exactly 0 maps to this finite depth).
pub const MAX_TAU: f64 = 745.0;

/// Transverse lattice spacing of the light-frame planes of a directional light, in units of
/// the smallest voxel side (the planes themselves are one voxel side apart). The transverse
/// interpolation error is O(h_⊥²): single scattering of `scenes/cumulus.toml` (96×96) against
/// exact transmittance has relative bias −0.57 % at spacing ½ and −0.14 % at ¼ (2026-12-04);
/// the built-in cloud (test `light_depth_grid_error_on_the_cloud`) −0.15 % and −0.04 %. Each
/// column is one traversal ([`Extinction::optical_depth_at_marks`]), so ¼ costs about what ½
/// did with one traversal per plane interval (cumulus: 0.08 s against 0.09 s).
pub const PLANE_SPACING: f64 = 0.25;

/// Lattice spacing of a sky light's planes ([`LightDepth::compute_with_sky`]), across and
/// along the light, in smallest voxel sides: a sky is cut into tens of directional lights,
/// each carrying a small share of its power, so each gets a coarser lattice than a sun's
/// (a quarter voxel across), read trilinearly (no exact segment back to a plane), and at
/// most [`SKY_PLANE_POINTS`] points. Single scattering of `scenes/sky-constant.toml` against
/// Mitsuba (64 lights, 2026-12-07): +0.07 % with 2^21-point planes; 1-voxel planes read the
/// same way were 2 % darker on a denser cloud (docs/sky.md).
pub const SKY_PLANE_SPACING: f64 = 0.5;

/// Most lattice points of one sky light's planes (256 kB of f32): a larger support widens the
/// sky lights' lattice beyond [`SKY_PLANE_SPACING`] instead of growing the memory and the
/// time (a column traversal per lattice point across). Measured on the two sky scenes (64
/// lights, single scattering against Mitsuba, 2026-12-08, docs/sky.md): 2^16 / 2^17 / 2^18
/// points: light depth 0.10 / 0.17 / 0.27 s and bias −0.62 / −0.19 / +0.10 % on
/// `sky-constant`, −1.78 / −1.38 / −1.16 % on `sky-sun-envmap`; the full images' errors
/// agree to 0.0005. The coarser lattice darkens (τ interpolated, then e^{−τ}: Jensen).
pub const SKY_PLANE_POINTS: usize = 1 << 16;

/// Optical depth at which a light-frame column stops (T = e^{−40} < 10⁻¹⁷).
pub const TAU_CUTOFF: f64 = 40.0;

/// τ to a directional light on planes perpendicular to its travel direction (module docs).
#[derive(Clone, Debug)]
pub struct PlaneDepth {
    /// Unit travel direction d of the light.
    d: [f64; 3],
    /// The light-frame lattice: axes, origin, spacings, point counts.
    lattice: Lattice,
    /// `tau[(k·nu + i)·nv + j]`: τ at plane k, lattice point (i, j) (f32: 7 digits in τ, an
    /// error of 10⁻⁷ relative in T).
    tau: Vec<f32>,
    /// Sky lights ([`SKY_PLANE_SPACING`]): τ trilinear between the planes instead of the
    /// exact segment back to the plane upstream.
    coarse: bool,
}

/// The light-frame lattice of a [`PlaneDepth`]: its axes, origin, spacings and point counts
/// (known before anything is traced, so that its memory can be checked first).
#[derive(Clone, Copy, Debug)]
struct Lattice {
    e1: [f64; 3],
    e2: [f64; 3],
    u0: f64,
    v0: f64,
    s0: f64,
    hu: f64,
    ds: f64,
    nu: usize,
    nv: usize,
    ns: usize,
}

impl Lattice {
    /// The lattice of a light along the unit vector `d` over `support`, the support of
    /// `g`'s density ([`DensityGrid::support`], `None` for an empty medium: computed once
    /// for all lights, it scans every voxel), `spacing` smallest voxel sides across the light.
    fn new(
        g: &DensityGrid,
        support: Option<([f64; 3], [f64; 3])>,
        d: [f64; 3],
        spacing: f64,
        coarse: bool,
    ) -> Option<Self> {
        let (lo, hi) = support?;
        // e1 ⟂ d from the axis least aligned with d, e2 = d × e1.
        let axis = (0..3)
            .min_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
            .unwrap_or(0);
        let mut a = [0.0; 3];
        a[axis] = 1.0;
        let ad = dot(a, d);
        let e1 = {
            let v = [0, 1, 2].map(|c| a[c] - ad * d[c]);
            let n = dot(v, v).sqrt();
            v.map(|c| c / n)
        };
        let e2 = [
            d[1] * e1[2] - d[2] * e1[1],
            d[2] * e1[0] - d[0] * e1[2],
            d[0] * e1[1] - d[1] * e1[0],
        ];
        // The support box's extent in the light frame.
        let mut ext_min = [f64::INFINITY; 3];
        let mut ext_max = [f64::NEG_INFINITY; 3];
        for c in 0..8 {
            let p = [0, 1, 2].map(|q| if c >> q & 1 == 1 { hi[q] } else { lo[q] });
            for (q, e) in [e1, e2, d].into_iter().enumerate() {
                let t = dot(p, e);
                ext_min[q] = ext_min[q].min(t);
                ext_max[q] = ext_max[q].max(t);
            }
        }
        let hmin = g.h().iter().fold(f64::INFINITY, |m, v| m.min(*v));
        let count = |q: usize, step: f64| ((ext_max[q] - ext_min[q]) / step).ceil() as usize + 1;
        // Coarse (sky) planes are read trilinearly, so they lie as close as their lattice,
        // which is widened where it would hold more than SKY_PLANE_POINTS.
        let spacing = if coarse {
            let h = spacing * hmin;
            let points = (count(0, h) * count(1, h) * count(2, h)) as f64;
            spacing * (points / SKY_PLANE_POINTS as f64).cbrt().max(1.0)
        } else {
            spacing
        };
        let (hu, ds) = (spacing * hmin, if coarse { spacing * hmin } else { hmin });
        let (nu, nv, ns) = (count(0, hu), count(1, hu), count(2, ds));
        Some(Self {
            e1,
            e2,
            u0: ext_min[0],
            v0: ext_min[1],
            s0: ext_min[2],
            hu,
            ds,
            nu,
            nv,
            ns,
        })
    }

    /// Peak bytes while the planes are built: the columns and the assembled `tau` (f32 each).
    fn peak_bytes(&self) -> u64 {
        let points = (self.nu as u64) * (self.nv as u64) * (self.ns as u64);
        2 * 4 * points + 24 * (self.nu as u64) * (self.nv as u64)
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl PlaneDepth {
    /// Traces the columns of a light travelling along the unit vector `d` through
    /// `support`, the support of `ext`'s density (`None` for an empty medium), with a
    /// transverse lattice of `spacing` smallest voxel sides; `coarse` lookups interpolate
    /// between planes instead of tracing back to one.
    fn compute_over(
        ext: &Extinction,
        support: Option<([f64; 3], [f64; 3])>,
        d: [f64; 3],
        spacing: f64,
        coarse: bool,
    ) -> Option<Self> {
        let lattice = Lattice::new(ext.grid, support, d, spacing, coarse)?;
        let Lattice {
            e1,
            e2,
            u0,
            v0,
            s0,
            hu,
            ds,
            nu,
            nv,
            ns,
        } = lattice;
        // Columns in parallel: column (i, j) walks the planes k = 0, 1, … downstream; the
        // planes k ≥ 1 lie at k·ds from plane 0.
        let marks: Vec<f64> = (1..ns).map(|k| k as f64 * ds).collect();
        let columns: Vec<Vec<f32>> = (0..nu * nv)
            .into_par_iter()
            .map(|c| {
                let (u, v) = (u0 + (c / nv) as f64 * hu, v0 + (c % nv) as f64 * hu);
                let at = |s: f64| [0, 1, 2].map(|q| u * e1[q] + v * e2[q] + s * d[q]);
                // τ at the planes k = 1, 2, … from plane 0, in one exact traversal.
                let mut depth = vec![0.0; ns - 1];
                ext.optical_depth_at_marks(at(s0), d, &marks, TAU_CUTOFF, &mut depth);
                std::iter::once(0.0f32)
                    .chain(depth.iter().map(|t| *t as f32))
                    .collect::<Vec<f32>>()
            })
            .collect();
        // Coarse planes are read at two neighbouring planes at once: column by column (the
        // two values one after the other); the others plane by plane.
        let tau = if coarse {
            columns.concat()
        } else {
            let mut tau = vec![0.0f32; nu * nv * ns];
            for (c, col) in columns.iter().enumerate() {
                for (k, t) in col.iter().enumerate() {
                    tau[k * nu * nv + c] = *t;
                }
            }
            tau
        };
        Some(Self {
            d,
            lattice,
            tau,
            coarse,
        })
    }

    /// τ from `x` to the light: the exact optical depth from `x` back to the plane upstream
    /// of it plus τ on that plane, bilinear between its lattice points (module docs).
    #[inline]
    pub fn tau(&self, ext: &Extinction, x: [f64; 3]) -> f64 {
        let s = dot(x, self.d) - self.lattice.s0;
        if s <= 0.0 {
            return 0.0; // upstream of the whole support
        }
        let k = (floor_fast(s / self.lattice.ds) as usize).min(self.lattice.ns - 1);
        let back = s - k as f64 * self.lattice.ds;
        if self.coarse {
            return self.between_planes(k, back / self.lattice.ds, x);
        }
        let near = if back > 0.0 {
            ext.optical_depth(x, self.d.map(|c| -c), back)
        } else {
            0.0
        };
        near + self.in_plane(k, x)
    }

    /// τ on plane `k` at the foot of `x`, bilinear between the lattice points (+∞ past the
    /// cutoff).
    #[inline]
    fn in_plane(&self, k: usize, x: [f64; 3]) -> f64 {
        let top_u = (self.lattice.nu - 1) as f64;
        let top_v = (self.lattice.nv - 1) as f64;
        let fu = ((dot(x, self.lattice.e1) - self.lattice.u0) / self.lattice.hu).clamp(0.0, top_u);
        let fv = ((dot(x, self.lattice.e2) - self.lattice.v0) / self.lattice.hu).clamp(0.0, top_v);
        let (i, j) = (floor_fast(fu) as usize, floor_fast(fv) as usize);
        let (i1, j1) = (
            (i + 1).min(self.lattice.nu - 1),
            (j + 1).min(self.lattice.nv - 1),
        );
        let (tu, tv) = (fu - i as f64, fv - j as f64);
        let plane = &self.tau
            [k * self.lattice.nu * self.lattice.nv..(k + 1) * self.lattice.nu * self.lattice.nv];
        let at = |a: usize, b: usize| plane[a * self.lattice.nv + b] as f64;
        let (t00, t01, t10, t11) = (at(i, j), at(i, j1), at(i1, j), at(i1, j1));
        if !(t00.is_finite() && t01.is_finite() && t10.is_finite() && t11.is_finite()) {
            return f64::INFINITY;
        }
        let lerp = |p: f64, q: f64, w: f64| p + w * (q - p);
        lerp(lerp(t00, t01, tv), lerp(t10, t11, tv), tu)
    }

    /// Coarse planes (stored column by column): τ trilinear between planes `k` and `k + 1`
    /// (`w` of the way to `k + 1`) and their lattice points; +∞ where a value read is.
    #[inline]
    fn between_planes(&self, k: usize, w: f64, x: [f64; 3]) -> f64 {
        let top_u = (self.lattice.nu - 1) as f64;
        let top_v = (self.lattice.nv - 1) as f64;
        let fu = ((dot(x, self.lattice.e1) - self.lattice.u0) / self.lattice.hu).clamp(0.0, top_u);
        let fv = ((dot(x, self.lattice.e2) - self.lattice.v0) / self.lattice.hu).clamp(0.0, top_v);
        let (i, j) = (floor_fast(fu) as usize, floor_fast(fv) as usize);
        let (i1, j1) = (
            (i + 1).min(self.lattice.nu - 1),
            (j + 1).min(self.lattice.nv - 1),
        );
        let (tu, tv) = (fu - i as f64, fv - j as f64);
        let k1 = (k + 1).min(self.lattice.ns - 1);
        let at = |a: usize, b: usize| {
            let col = (a * self.lattice.nv + b) * self.lattice.ns;
            (self.tau[col + k] as f64, self.tau[col + k1] as f64)
        };
        let (c00, c01, c10, c11) = (at(i, j), at(i, j1), at(i1, j), at(i1, j1));
        let lerp = |p: f64, q: f64, w: f64| p + w * (q - p);
        let plane = |sel: fn((f64, f64)) -> f64| {
            let (a, b, c, d) = (sel(c00), sel(c01), sel(c10), sel(c11));
            if !(a.is_finite() && b.is_finite() && c.is_finite() && d.is_finite()) {
                return f64::INFINITY;
            }
            lerp(lerp(a, b, tv), lerp(c, d, tv), tu)
        };
        let here = plane(|p| p.0);
        if w == 0.0 || k1 == k || !here.is_finite() {
            return here;
        }
        here + w * (plane(|p| p.1) - here)
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.tau.len() * std::mem::size_of::<f32>()
    }
}

/// τ to each light at the density-voxel centres.
#[derive(Clone, Debug)]
pub struct LightDepth {
    /// World position of node (0, 0, 0): the centre of voxel (0, 0, 0).
    origin: [f64; 3],
    /// Node spacing (the voxel size).
    h: [f64; 3],
    /// Nodes per axis (the density resolution).
    res: [usize; 3],
    /// `tau[light][(i·ny + j)·nz + k]` (x slowest, the order of the
    /// solve grid's cells).
    tau: Vec<Vec<f64>>,
    /// Light-frame planes per light (directional lights; `None`: the voxel-centre grid).
    planes: Vec<Option<PlaneDepth>>,
}

impl LightDepth {
    /// The grids for every light: light-frame planes ([`PlaneDepth`]) for directional
    /// lights, the voxel-centre grid ([`Self::compute_voxel_centres`]) for point lights.
    ///
    /// A point light's grid is traced only at the voxel centres within one voxel (the
    /// 26-neighbourhood) of a non-empty voxel: a lookup at a point of non-zero density
    /// (either filter) reads only the 8 centres around it, which all lie there, so every value
    /// read equals [`Self::compute_voxel_centres`]'s; the others hold 0. This is the one
    /// optical-depth grid of a render: the first-scatter source and the camera rays read it.
    pub fn compute(ext: &Extinction, lights: &[Light]) -> Self {
        Self::compute_with_sky(ext, lights, None)
    }

    /// [`Self::compute`] where the lights from index `sky_from` on are a sky's
    /// ([`crate::sky`]): their planes have the coarser lattice [`SKY_PLANE_SPACING`] and are
    /// read trilinearly.
    pub fn compute_with_sky(ext: &Extinction, lights: &[Light], sky_from: Option<usize>) -> Self {
        let point = |l: &Light| matches!(l, Light::Point { .. });
        // Only point lights trace the voxel centres: no mask without one.
        let near = if lights.iter().any(point) {
            near_medium_mask(ext.grid)
        } else {
            Vec::new()
        };
        let mut ld = Self::compute_voxel_centres_where(ext, lights, point, |c| near[c]);
        ld.planes = Self::planes(ext, lights, sky_from.unwrap_or(usize::MAX));
        ld
    }

    /// The peak bytes [`Self::compute_with_sky`] allocates for `lights` over `g`'s density,
    /// computed from the lattices' sizes without tracing anything: per directional light
    /// its planes (the columns and the assembled grid, f32 each), per point light a value
    /// per voxel (f64) and the near-medium mask. The render checks it against its memory
    /// limit before the grids are made (issue 53).
    pub fn estimate_bytes(g: &DensityGrid, lights: &[Light], sky_from: Option<usize>) -> u64 {
        let voxels: u64 = g.res.iter().map(|&n| n as u64).product();
        let sky_from = sky_from.unwrap_or(usize::MAX);
        let mut bytes = 0u64;
        let mut any_point = false;
        let support = g.support();
        for (i, l) in lights.iter().enumerate() {
            match l {
                Light::Directional { direction, .. } => {
                    let n = dot(*direction, *direction).sqrt();
                    let d = direction.map(|c| c / n);
                    let lattice = if i >= sky_from {
                        Lattice::new(g, support, d, SKY_PLANE_SPACING, true)
                    } else {
                        Lattice::new(g, support, d, PLANE_SPACING, false)
                    };
                    bytes += lattice.map_or(0, |l| l.peak_bytes());
                }
                Light::Point { .. } => {
                    any_point = true;
                    bytes += 8 * voxels;
                }
            }
        }
        if any_point {
            bytes += voxels;
        }
        bytes
    }

    /// Light-frame planes of the directional lights (`None` for point lights); the lights
    /// from `sky_from` on get the sky's coarse planes.
    fn planes(ext: &Extinction, lights: &[Light], sky_from: usize) -> Vec<Option<PlaneDepth>> {
        let support = ext.grid.support();
        lights
            .iter()
            .enumerate()
            .map(|(i, l)| match l {
                Light::Directional { direction, .. } => {
                    let n = dot(*direction, *direction).sqrt();
                    let d = direction.map(|c| c / n);
                    if i >= sky_from {
                        PlaneDepth::compute_over(ext, support, d, SKY_PLANE_SPACING, true)
                    } else {
                        PlaneDepth::compute_over(ext, support, d, PLANE_SPACING, false)
                    }
                }
                Light::Point { .. } => None,
            })
            .collect()
    }

    /// Traces τ at the voxel-centre nodes for every light (also directional ones), in
    /// parallel: the nodes within one voxel of an occupied voxel (the only ones a lookup
    /// inside the density's support reaches); the others hold 0. Kept to measure the
    /// light-frame planes against (module docs).
    pub fn compute_voxel_centres(ext: &Extinction, lights: &[Light]) -> Self {
        Self::compute_voxel_centres_where(ext, lights, |_| true, |_| true)
    }

    /// τ at the voxel centres for the lights where `traced` holds: at the nodes of the
    /// occupied box grown by one voxel where `node` (of the linear index
    /// `(i·ny + j)·nz + k`) holds; 0 at the others.
    fn compute_voxel_centres_where(
        ext: &Extinction,
        lights: &[Light],
        traced: impl Fn(&Light) -> bool,
        node: impl Fn(usize) -> bool + Sync,
    ) -> Self {
        let g = ext.grid;
        let mut ld = Self::empty(g, lights.len());
        let Some((lo, hi)) = g.occupied_range() else {
            return ld;
        };
        let first = lo.map(|c| c.saturating_sub(1));
        let last = [0, 1, 2].map(|d| (hi[d] + 1).min(g.res[d] - 1));
        let [_, ny, nz] = g.res;
        let centres = ld.origin;
        let h = ld.h;
        let n: usize = g.res.iter().product();
        for (light, tau) in lights.iter().zip(&mut ld.tau) {
            if !traced(light) {
                continue;
            }
            *tau = vec![0.0; n];
            tau.par_chunks_mut(ny * nz)
                .enumerate()
                .filter(|(i, _)| (first[0]..=last[0]).contains(i))
                .for_each(|(i, plane)| {
                    for j in first[1]..=last[1] {
                        for k in first[2]..=last[2] {
                            if !node((i * ny + j) * nz + k) {
                                continue;
                            }
                            let x = [
                                centres[0] + i as f64 * h[0],
                                centres[1] + j as f64 * h[1],
                                centres[2] + k as f64 * h[2],
                            ];
                            let inc = light.incident(x);
                            plane[j * nz + k] = if inc.distance == 0.0 {
                                0.0
                            } else {
                                ext.optical_depth(x, inc.travel.map(|c| -c), inc.distance)
                                    .min(MAX_TAU)
                            };
                        }
                    }
                });
        }
        ld
    }

    fn empty(g: &DensityGrid, lights: usize) -> Self {
        let h = g.h();
        Self {
            origin: [0, 1, 2].map(|d| g.bbox_min[d] + 0.5 * h[d]),
            h,
            res: g.res,
            // Allocated for the lights traced at the voxel centres only (point lights).
            tau: vec![Vec::new(); lights],
            planes: vec![None; lights],
        }
    }

    /// Lights held.
    pub fn lights(&self) -> usize {
        self.tau.len()
    }

    /// Optical depth from `x` to light `light`: from its light-frame planes where it has
    /// them ([`PlaneDepth::tau`], which traces the last part exactly through `ext`), else
    /// trilinear between the voxel centres (clamped to the outermost ones).
    #[inline]
    pub fn tau(&self, ext: &Extinction, light: usize, x: [f64; 3]) -> f64 {
        match &self.planes[light] {
            Some(p) => p.tau(ext, x),
            None => self.tau_voxel_centres(light, x),
        }
    }

    /// Bytes held by the grids.
    pub fn bytes(&self) -> usize {
        self.tau.iter().map(|t| t.len() * 8).sum::<usize>()
            + self
                .planes
                .iter()
                .flatten()
                .map(PlaneDepth::bytes)
                .sum::<usize>()
    }

    /// The voxel-centre grid's τ (trilinear, clamped to the outermost centres).
    #[inline]
    fn tau_voxel_centres(&self, light: usize, x: [f64; 3]) -> f64 {
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        let mut t = [0.0f64; 3];
        for d in 0..3 {
            let top = (self.res[d] - 1) as f64;
            let u = ((x[d] - self.origin[d]) / self.h[d]).clamp(0.0, top);
            let f = floor_fast(u);
            lo[d] = f as usize;
            hi[d] = (lo[d] + 1).min(self.res[d] - 1);
            t[d] = u - f;
        }
        let [_, ny, nz] = self.res;
        let data = &self.tau[light];
        if data.is_empty() {
            return 0.0; // a directional light over an empty medium: nothing in the way
        }
        let at = |i: usize, j: usize, k: usize| data[(i * ny + j) * nz + k];
        let lerp = |a: f64, b: f64, s: f64| a + s * (b - a);
        let c00 = lerp(at(lo[0], lo[1], lo[2]), at(lo[0], lo[1], hi[2]), t[2]);
        let c01 = lerp(at(lo[0], hi[1], lo[2]), at(lo[0], hi[1], hi[2]), t[2]);
        let c10 = lerp(at(hi[0], lo[1], lo[2]), at(hi[0], lo[1], hi[2]), t[2]);
        let c11 = lerp(at(hi[0], hi[1], lo[2]), at(hi[0], hi[1], hi[2]), t[2]);
        lerp(lerp(c00, c01, t[1]), lerp(c10, c11, t[1]), t[0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`LightDepth::compute`] traces a point light's voxel-centre grid only near the
    /// medium: there it equals the grid traced at every centre of the occupied box
    /// ([`LightDepth::compute_voxel_centres`]), elsewhere it holds 0, and both give the same
    /// τ at any point of non-zero density (both filters).
    #[test]
    fn the_grid_near_the_medium_agrees_where_it_is_read() {
        use crate::medium::DensityFilter;
        // A 9³ grid with two blobs of density and empty space between them and the faces.
        let n = 9;
        let mut data = vec![0.0f32; n * n * n];
        for (i, j, k, v) in [
            (2, 2, 2, 1.0),
            (3, 2, 2, 0.5),
            (6, 6, 5, 2.0),
            (6, 5, 5, 0.3),
        ] {
            data[(k * n + j) * n + i] = v;
        }
        let base = DensityGrid::new([n; 3], [-1.0; 3], [1.0; 3], data).unwrap();
        let lights = [
            Light::Point {
                position: [1.7, 2.1, -1.3],
                power: 1.0,
            },
            Light::Directional {
                direction: [0.3, -0.9, 0.3],
                irradiance: 1.0,
            },
        ];
        for filter in [DensityFilter::Trilinear, DensityFilter::Nearest] {
            let g = base.clone().with_filter(filter);
            let ext = Extinction {
                grid: &g,
                scale: 3.0,
            };
            let full = LightDepth::compute_voxel_centres(&ext, &lights[..1]);
            let near = LightDepth::compute(&ext, &lights);
            assert!(near.planes[0].is_none() && near.planes[1].is_some());
            let (mut skipped, mut shadowed) = (0, 0);
            for c in 0..n * n * n {
                let (i, j, k) = (c / (n * n), (c / n) % n, c % n);
                let close = (0..n * n * n).any(|o| {
                    let (a, b, d) = (o % n, (o / n) % n, o / (n * n));
                    g.at(a, b, d) > 0.0
                        && a.abs_diff(i) <= 1
                        && b.abs_diff(j) <= 1
                        && d.abs_diff(k) <= 1
                });
                if close {
                    assert_eq!(near.tau[0][c], full.tau[0][c], "{filter:?} ({i}, {j}, {k})");
                    shadowed += usize::from(near.tau[0][c] > 0.0);
                } else {
                    assert_eq!(near.tau[0][c], 0.0);
                    skipped += 1;
                }
            }
            assert!(skipped > 500 && shadowed > 10, "{skipped} {shadowed}");
            let mut read = 0;
            // A lattice three times finer than the voxels, off the voxel planes.
            for s in 0..27 * 27 * 27 {
                let x =
                    [s % 27, (s / 27) % 27, s / 729].map(|a| -1.0 + 2.0 * (a as f64 + 0.37) / 27.0);
                if ext.sigma_t(x) > 0.0 {
                    read += 1;
                    assert_eq!(
                        near.tau(&ext, 0, x),
                        full.tau(&ext, 0, x),
                        "{filter:?} {x:?}"
                    );
                }
            }
            assert!(read > 20, "{read}");
        }
    }

    #[test]
    fn linear_depth_is_interpolated_exactly_and_matches_the_traversal() {
        // Homogeneous box [0,2]×[0,1]×[0,1], light straight down (−y): τ = σ_t (1 − y),
        // linear, so trilinear interpolation is exact (to rounding).
        let g = DensityGrid::new([4, 3, 2], [0.0; 3], [2.0, 1.0, 1.0], vec![1.0; 24]).unwrap();
        let ext = Extinction {
            grid: &g,
            scale: 3.0,
        };
        let light = Light::Directional {
            direction: [0.0, -1.0, 0.0],
            irradiance: 1.0,
        };
        for ld in [
            LightDepth::compute_voxel_centres(&ext, std::slice::from_ref(&light)),
            LightDepth::compute(&ext, std::slice::from_ref(&light)),
        ] {
            assert_eq!(ld.lights(), 1);
            // Between the outermost centres (y ∈ [1/6, 5/6]); the planes anywhere.
            for x in [[0.3, 0.2, 0.7], [1.99, 0.8, 0.01], [1.0, 0.5, 0.5]] {
                let want = 3.0 * (1.0 - x[1]);
                assert!((ld.tau(&ext, 0, x) - want).abs() < 1e-12, "{x:?}");
            }
        }
        // An oblique point light: at the nodes the grid holds the exact traversal.
        let p = Light::Point {
            position: [2.5, 1.5, 0.3],
            power: 1.0,
        };
        let ld = LightDepth::compute(&ext, std::slice::from_ref(&p));
        let x = [0.75, 0.5, 0.25];
        let inc = p.incident(x);
        let exact = ext.optical_depth(x, inc.travel.map(|c| -c), inc.distance);
        assert!((ld.tau(&ext, 0, x) - exact).abs() < 1e-12);
    }

    #[test]
    fn an_empty_medium_has_zero_depth() {
        let g = DensityGrid::new([2, 2, 2], [0.0; 3], [1.0; 3], vec![0.0; 8]).unwrap();
        let ext = Extinction {
            grid: &g,
            scale: 3.0,
        };
        let light = Light::Directional {
            direction: [0.0, -1.0, 0.0],
            irradiance: 1.0,
        };
        let ld = LightDepth::compute(&ext, &[light]);
        assert_eq!(ld.tau(&ext, 0, [0.5; 3]), 0.0);
    }

    /// The light-frame planes of an oblique directional light through a random trilinear
    /// grid: at the lattice points they hold the exact depth (so a lookup at a point on a
    /// plane and lattice line is exact), anywhere else the error is the transverse
    /// interpolation's, far below the voxel-centre grid's along-the-light error.
    #[test]
    fn planes_are_exact_on_their_lattice_and_beat_the_voxel_centre_grid() {
        let n = 6;
        let mut state = 12345u64;
        let data: Vec<f32> = (0..n * n * n)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 40) as f32 / (1u64 << 24) as f32
            })
            .collect();
        let g = DensityGrid::new([n; 3], [0.0; 3], [1.0; 3], data).unwrap();
        let ext = Extinction {
            grid: &g,
            scale: 6.0 * n as f64, // σ_t h up to 6: a dense cloud
        };
        let dir = [0.5f64, -1.0, -0.3];
        let norm = dot(dir, dir).sqrt();
        let d = dir.map(|c| c / norm);
        let light = Light::Directional {
            direction: d,
            irradiance: 1.0,
        };
        let planes = LightDepth::compute(&ext, std::slice::from_ref(&light));
        let centres = LightDepth::compute_voxel_centres(&ext, std::slice::from_ref(&light));
        let p = planes.planes[0].as_ref().unwrap();
        let exact = |x: [f64; 3]| ext.optical_depth(x, d.map(|c| -c), f64::INFINITY);
        // A lattice point of plane k, moved downstream by part of a plane interval.
        let (i, j, k) = (p.lattice.nu / 2, p.lattice.nv / 2, p.lattice.ns / 2);
        let x = [0, 1, 2].map(|q| {
            (p.lattice.u0 + i as f64 * p.lattice.hu) * p.lattice.e1[q]
                + (p.lattice.v0 + j as f64 * p.lattice.hu) * p.lattice.e2[q]
                + (p.lattice.s0 + (k as f64 + 0.4) * p.lattice.ds) * p.d[q]
        });
        assert!(g.contains(x));
        let want = exact(x);
        assert!(
            (planes.tau(&ext, 0, x) - want).abs() < 1e-5 * want.max(1.0),
            "{} vs {want}",
            planes.tau(&ext, 0, x)
        );
        // Random points inside: RMS error of T = e^{−τ} against exact transmittance.
        let (mut e_planes, mut e_centres, mut count) = (0.0, 0.0, 0);
        for _ in 0..2000 {
            let x = [0, 1, 2].map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                0.02 + 0.96 * ((state >> 11) as f64 / (1u64 << 53) as f64)
            });
            let t = (-exact(x)).exp();
            e_planes += ((-planes.tau(&ext, 0, x)).exp() - t).powi(2);
            e_centres += ((-centres.tau(&ext, 0, x)).exp() - t).powi(2);
            count += 1;
        }
        let (rp, rc) = (
            (e_planes / count as f64).sqrt(),
            (e_centres / count as f64).sqrt(),
        );
        // Measured: 2.4e-2 against 8.5e-2 (σ_t h up to 6 on white noise, the worst case for
        // the transverse interpolation); require at least a factor 2.
        assert!(
            rp < 0.5 * rc,
            "planes RMS {rp:.3e} vs voxel centres {rc:.3e}"
        );
    }
}
