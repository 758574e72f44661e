//! The deterministic renderer (the default of `pn render`): per pixel a fixed k×k pattern of
//! camera rays, and along each ray the in-scattered radiance integrated by ray marching,
//! with no random numbers (docs/rendering.md, docs/design.md §6).
//!
//! **What is integrated.** For a camera ray x(t) = o + t·ω (ω_o = −ω towards the camera)
//!
//! ```text
//! L = ∫ T(o, x) σ_s(x) [S_single(x, ω_o) + S_ms(x, ω_o)] dt,
//! S_single = Σ_lights p(d·ω_o) T(x, light) E(x),    S_ms = Σ_{l,m} λ_l p_l L_l^m(x) Y_l^m(ω_o)
//! ```
//!
//! with L_l^m the un-staggered solution ([`MsField`], trilinear between solve-cell centres;
//! the coefficients λ_l p_l Y_l^m(ω_o) are computed once per ray) and T(x, light) = e^{−τ}
//! with τ interpolated from the optical-depth grid of [`LightDepth`].
//!
//! **Quadrature: the exponential midpoint rule.** The part of the ray inside the support of
//! the density ([`DensityGrid::support`]) is cut at the planes where the filtered density
//! has a kink or a jump — voxel faces for the nearest filter, voxel centres for the
//! trilinear one — so that σ_t is a polynomial (constant, resp. trilinear) on every piece;
//! pieces whose density vanishes are skipped (empty-space skipping at voxel granularity).
//! Each piece of length ℓ is split into ⌈ℓ/Δ⌉ equal steps, Δ = `step` × smallest voxel
//! side. On a step of length δ with midpoint m:
//!
//! ```text
//! τ = σ_t(m) δ;   L += T (1 − e^{−τ}) albedo(m) S(m);   T ← T e^{−τ}
//! ```
//!
//! This is the exact integral ∫₀^δ T e^{−σ_t s} σ_s S ds when σ_t, albedo and S are constant
//! on the step, so it is exact for a homogeneous medium under constant in-scattering, never
//! negative, and stable in optically thick steps (the weight 1 − e^{−τ} ≤ 1 and T only
//! decreases; the image of an opaque step is albedo·S, the right limit).
//!
//! **Error bound.** With smooth data on a step (σ_t, albedo, S twice differentiable), the
//! midpoint values differ from the step averages by (δ²/24)·f'' + O(δ⁴), and τ by
//! (δ³/24)·σ_t''; summed over a ray, the error of L is
//! `|ΔL| ≤ C·Δ²·∫ T σ_t (|S''|/σ_t·… + |σ_t''| … ) dt`, i.e. **O(Δ²)**, second order in
//! `step`: the terms are the second derivatives along the ray of the extinction, the albedo,
//! the single-scattering source (E·T_light·p: smooth unless the ray passes close to a point
//! light, where E ∝ 1/r²) and S_ms. Kinks not on the cutting planes — the solve-grid cell
//! centres of S_ms, the node planes of the light-depth grid — put an O(δ²·[f']) error in the
//! step that contains them, O(Δ²) again in total (one kink per solve cell crossed). So the
//! quadrature error falls by 4 when `step` halves; `tests` measures the order.
//!
//! **What the step does not control.** (1) The light-depth grid: for a directional light τ
//! is interpolated bilinearly across the light on planes with a quarter-voxel lattice and
//! one voxel apart along the light, with the last part of the way traced exactly
//! ([`LightDepth`], module docs there); measured on the built-in cloud (48×48 pixel-centre
//! rays, trilinear): 0.18 % relative RMS, −0.04 % bias against exact transmittance (with a
//! half-voxel lattice 0.70 %, −0.15 %; the voxel-centre grid: 3.6 %, −0.97 %), which
//! [`MarchSettings::exact_transmittance`] removes at several times the cost. (2) The pixel
//! filter: k×k stratified sub-pixel rays are the midpoint rule of the box filter (O(1/k²)
//! for a smooth image, O(1/k) at silhouettes). (3) The cutoff: marching stops when T <
//! `cutoff`; the light not collected is `∫_rest T σ_s S dt ≤ cutoff · max_x(albedo·S)`
//! (T ≤ cutoff on the rest, and ∫ T σ_t dt ≤ T at the stop), e.g. ≤ 10⁻⁴ of the brightest
//! in-scattered radiance with the default cutoff 10⁻⁴ — for an optically thick cloud whose
//! pixels are ≈ albedo·S of its surface, a relative loss of order 10⁻⁴. (4) The sky grid:
//! a sky's K lights are not summed at every step but read from a per-view grid of their
//! sum ([`SkyView`], `sky_grid` voxel sides apart; 0 sums them at every step), an
//! interpolation error of O(h²) in the grid's spacing (docs/sky.md).

use super::camera::Camera;
use super::light_depth::LightDepth;
use super::lights::{phase_value, Light};
use super::medium::floor_fast;
use super::medium::{DensityFilter, DensityGrid};
use super::renderer::{Image, MsField};
use super::scene::{MsLookup, RenderScene};
use super::shadow::{walk_lattice, Extinction};
use super::sky_view::{SkySource, SkyView};
use crate::progress::{ProgressCallback, RowCounter};
use rayon::prelude::*;

/// Settings of the deterministic renderer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchSettings {
    /// Camera rays per pixel: a square number k², in a k×k stratified pattern.
    pub rays: usize,
    /// Step length in units of the smallest voxel side.
    pub step: f64,
    /// Stop marching a ray when its transmittance falls below this.
    pub cutoff: f64,
    /// Exact transmittance to the lights at every step (a traversal each) instead of the
    /// light-depth grid: free of the grid's interpolation error, several times slower for
    /// the trilinear filter.
    pub exact_transmittance: bool,
    /// Node spacing, in voxel sides, of the grid on which the sky's single scattering is
    /// tabulated once per view ([`SkyView`]); 0: every sky light at every step.
    pub sky_grid: f64,
}

impl MarchSettings {
    /// Rays per side of the pixel's pattern (√rays).
    pub fn rays_per_side(&self) -> usize {
        (self.rays as f64).sqrt().round() as usize
    }
}

/// The deterministic renderer of a scene with (optionally) its multiple-scattering solution.
pub struct Marcher<'a> {
    scene: &'a RenderScene,
    density: &'a DensityGrid,
    ms: Option<&'a MsField>,
    light_depth: &'a LightDepth,
    settings: MarchSettings,
    /// Step length Δ.
    delta: f64,
    /// The cutting lattice: planes at `lattice_min + c·h`, `cells` pieces per axis.
    lattice_min: [f64; 3],
    h: [f64; 3],
    cells: [usize; 3],
    /// Whether the density can be > 0 in lattice cell `(cz·ny + cy)·nx + cx`.
    occupied: Vec<bool>,
    /// The density's support (None: empty medium).
    support: Option<([f64; 3], [f64; 3])>,
    /// Exact transmittance to the lights by traversal instead of the grid.
    exact: bool,
    /// The extinction on the way to the lights (σ_t′ of delta-M, [`crate::delta_m`]; `ext`
    /// without it): the optical depth of the single scattering's light leg.
    light_ext: Extinction<'a>,
    /// Length of the exactly traversed part of each light ray ([`NEAR_VOXELS`] voxels).
    near: f64,
}

/// Voxel sides of every ray to a light traversed exactly before the grid takes over (see
/// `Marcher::tau_to_light`; [`Marcher::with_near_voxels`] changes it). 0 by measurement: on
/// the built-in cloud (64³, 48×48 rays, trilinear) the grid's relative RMS error against
/// exact transmittance is 3.6 % with 0, 3.5 % with 1, 3.0 % with 2 and 2.0 % with 4 voxels
/// traced, at 1×, 1.8×, 2.5× and 3.3× the render time: the error is the grid's interpolation
/// across voxel-scale density detail everywhere, not mainly the kink where the light enters.
pub const NEAR_VOXELS: f64 = 0.0;

/// The MS in-scattering along one ray: the coefficients of ω_o and the 8 corner values of
/// the last solve cell looked up (reused while the ray stays between the same centres).
struct MsCursor<'a> {
    ms: &'a MsField,
    coeffs: Vec<f64>,
    lo: [usize; 3],
    corners: [f64; 8],
}

impl<'a> MsCursor<'a> {
    fn new(ms: &'a MsField, wo: [f64; 3]) -> Self {
        Self {
            ms,
            coeffs: ms.coefficients(wo),
            lo: [usize::MAX; 3],
            corners: [0.0; 8],
        }
    }

    /// `Σ coeffs · L(x)`, trilinear between cell centres (clamped), 0 outside the grid:
    /// the same value as [`MsField::inscatter`].
    #[inline]
    fn eval(&mut self, x: [f64; 3]) -> f64 {
        let g = &self.ms.grid;
        if (0..3).any(|d| !(x[d] >= g.min[d] && x[d] <= g.max[d])) {
            return 0.0;
        }
        let mut lo = [0usize; 3];
        let mut t = [0.0f64; 3];
        for d in 0..3 {
            let n = g.res[d];
            let u = ((x[d] - g.min[d]) / g.h(d) - 0.5).clamp(0.0, (n - 1) as f64);
            let f = floor_fast(u);
            lo[d] = f as usize;
            t[d] = u - f;
        }
        if lo != self.lo {
            self.lo = lo;
            let pc = self.ms.moments.per_cell;
            let [_, ny, nz] = g.res;
            for (corner, v) in self.corners.iter_mut().enumerate() {
                let idx: [usize; 3] =
                    std::array::from_fn(|d| (lo[d] + (corner >> d & 1)).min(g.res[d] - 1));
                let base = ((idx[0] * ny + idx[1]) * nz + idx[2]) * pc;
                let cell = &self.ms.moments.data[base..base + pc];
                *v = cell.iter().zip(&self.coeffs).map(|(a, b)| a * b).sum();
            }
        }
        if self.ms.lookup == MsLookup::Nearest {
            // The containing cell is the corner nearest to x.
            let corner = (0..3).fold(0, |acc, d| acc | (usize::from(t[d] >= 0.5) << d));
            return self.corners[corner];
        }
        let c = &self.corners;
        let lerp = |a: f64, b: f64, s: f64| a + s * (b - a);
        let x00 = lerp(c[0], c[1], t[0]);
        let x10 = lerp(c[2], c[3], t[0]);
        let x01 = lerp(c[4], c[5], t[0]);
        let x11 = lerp(c[6], c[7], t[0]);
        lerp(lerp(x00, x10, t[1]), lerp(x01, x11, t[1]), t[2])
    }
}

impl<'a> Marcher<'a> {
    /// Prepares the renderer: the cutting lattice of `density`'s filter and its occupancy.
    /// `light_depth` must hold the scene's lights in order ([`LightDepth::compute`]).
    pub fn new(
        scene: &'a RenderScene,
        density: &'a DensityGrid,
        ms: Option<&'a MsField>,
        light_depth: &'a LightDepth,
        settings: MarchSettings,
    ) -> Self {
        let h = density.h();
        let n = density.res;
        let (lattice_min, cells) = match density.filter {
            DensityFilter::Nearest => (density.bbox_min, n),
            // Pieces between voxel centres; the first and last are clipped to the box.
            DensityFilter::Trilinear => (
                [0, 1, 2].map(|d| density.bbox_min[d] - 0.5 * h[d]),
                n.map(|v| v + 1),
            ),
        };
        let [cx, cy, cz] = cells;
        let mut occupied = vec![false; cx * cy * cz];
        // A lattice cell may be non-zero where one of the voxels whose filter reaches it is.
        let reach = |c: usize, d: usize| -> (usize, usize) {
            match density.filter {
                DensityFilter::Nearest => (c, c),
                DensityFilter::Trilinear => (c.saturating_sub(1), c.min(n[d] - 1)),
            }
        };
        for k in 0..cz {
            let (k0, k1) = reach(k, 2);
            for j in 0..cy {
                let (j0, j1) = reach(j, 1);
                for i in 0..cx {
                    let (i0, i1) = reach(i, 0);
                    let any = (k0..=k1).any(|kk| {
                        (j0..=j1).any(|jj| (i0..=i1).any(|ii| density.at(ii, jj, kk) > 0.0))
                    });
                    occupied[(k * cy + j) * cx + i] = any;
                }
            }
        }
        let hmin = h.iter().fold(f64::INFINITY, |m, v| m.min(*v));
        Self {
            scene,
            density,
            ms,
            light_depth,
            settings,
            delta: settings.step * hmin,
            lattice_min,
            h,
            cells,
            occupied,
            support: if scene.medium.sigma_t_scale > 0.0 {
                density.support()
            } else {
                None
            },
            exact: settings.exact_transmittance,
            light_ext: Extinction {
                grid: density,
                scale: scene.medium.sigma_t_scale,
            },
            near: NEAR_VOXELS * h.iter().fold(0.0f64, |m, v| m.max(*v)),
        }
    }

    /// Optical depth from `x` to light `li`: the first `near` of the way exactly
    /// ([`Extinction::optical_depth`]), the rest from the grid at the point y reached, and 0
    /// beyond the medium's box (a ray leaving the convex box never re-enters it). The exact
    /// near part removes the grid's worst error: τ has a kink where the light enters the
    /// medium (its gradient jumps from 0 to σ_t there), right where most single scattering
    /// happens, and interpolating across that kink errs by O(σ_t h).
    #[inline]
    fn tau_to_light(&self, li: usize, x: [f64; 3], back: [f64; 3], distance: f64) -> f64 {
        if self.exact {
            return self.light_ext.optical_depth(x, back, distance);
        }
        let s = self.near.min(distance);
        // (NEAR_VOXELS = 0 by default: no traversal of an empty segment per light and step.)
        let near = if s > 0.0 {
            self.light_ext.optical_depth(x, back, s)
        } else {
            0.0
        };
        if s >= distance {
            return near;
        }
        let y = [0, 1, 2].map(|d| x[d] + s * back[d]);
        if !self.density.contains(y) {
            return near;
        }
        near + self.light_depth.tau(&self.light_ext, li, y)
    }

    /// Reads the light leg's optical depth through `ext` (delta-M's σ_t′,
    /// [`crate::LightLeg::extinction`]); `light_depth` must have been computed from it.
    pub fn with_light_extinction(mut self, ext: Extinction<'a>) -> Self {
        self.light_ext = ext;
        self
    }

    /// Traces the first `voxels` voxel sides of every light ray exactly (default
    /// [`NEAR_VOXELS`]; 0: the grid alone). For the tests.
    #[cfg(test)]
    pub(crate) fn with_near_voxels(mut self, voxels: f64) -> Self {
        self.near = voxels.max(0.0) * self.density.h().iter().fold(0.0f64, |m, v| m.max(*v));
        self
    }

    /// Uses the exact optical depth to the lights (a voxel traversal per step and light,
    /// [`Extinction::optical_depth`]) instead of the interpolated grid: slower, and free of
    /// the grid's interpolation error (for measuring it in the tests).
    #[cfg(test)]
    pub(crate) fn with_exact_transmittance(mut self) -> Self {
        self.exact = true;
        self
    }

    /// The radiance arriving at `origin` along the unit direction `dir` (from the medium
    /// towards `origin` is −`dir`), every sky light evaluated at every step.
    #[cfg(test)]
    pub fn radiance(&self, origin: [f64; 3], dir: [f64; 3]) -> f64 {
        self.radiance_with(origin, dir, None::<&SkyView<fn([f64; 3], [f64; 3]) -> f64>>)
    }

    /// The sky's single scattering towards `eye` tabulated on a grid over the medium's
    /// support ([`SkyView`]), or `None` without sky lights, without a medium or with
    /// `sky_grid` = 0.
    pub fn sky_view(&self, eye: [f64; 3]) -> Option<SkyView<impl SkySource + '_>> {
        let sky = self.scene.sky_lights.as_deref()?;
        let (lo, hi) = self.support?;
        if self.settings.sky_grid <= 0.0 || sky.lights.is_empty() {
            return None;
        }
        let hmin = self.h.iter().fold(f64::INFINITY, |m, v| m.min(*v));
        let phase = &self.scene.phase;
        let lights = &self.scene.lights[sky.first..];
        Some(SkyView::new(
            lo,
            hi,
            self.settings.sky_grid * hmin,
            eye,
            |x, wo| {
                let mut src = 0.0;
                for (k, l) in lights.iter().enumerate() {
                    let li = sky.first + k;
                    let inc = l.incident(x);
                    let pe = sky.phase_value(phase, li, dot(inc.travel, wo)) * inc.irradiance;
                    if pe > 0.0 {
                        let back = inc.travel.map(|c| -c);
                        src += pe * (-self.tau_to_light(li, x, back, inc.distance)).exp();
                    }
                }
                src
            },
        ))
    }

    /// [`Self::radiance`], with the sky lights' single scattering read from `sky` where
    /// given (tabulated for this ray's origin, [`Self::sky_view`]).
    fn radiance_with<F: SkySource>(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        sky: Option<&SkyView<F>>,
    ) -> f64 {
        // The sky seen along the ray (unless hidden), attenuated by the whole ray.
        let background = match (&self.scene.sky, self.scene.render.hide_emitters) {
            (Some(sky), false) => sky.radiance(dir),
            _ => 0.0,
        };
        let Some((smin, smax)) = self.support else {
            return background;
        };
        let Some((t0, t1)) = clip_box(origin, dir, smin, smax) else {
            return background;
        };
        let wo = dir.map(|c| -c);
        let phase = &self.scene.phase;
        let lights = &self.scene.lights;
        let sky_lights = self.scene.sky_lights.as_deref();
        // The lights evaluated at every step: all of them, or the scene's own without `sky`.
        let stepped = match (sky, sky_lights) {
            (Some(_), Some(s)) => s.first,
            _ => lights.len(),
        };
        let lights = &lights[..stepped];
        // p·E of the directional lights: constant along the ray. A sky light reads the phase
        // function averaged over its region (crate::sky::CapPhase).
        let directional: Vec<Option<f64>> = lights
            .iter()
            .enumerate()
            .map(|(li, l)| match l {
                Light::Directional {
                    direction,
                    irradiance,
                } => {
                    let mu = dot(*direction, wo);
                    let p = match sky_lights {
                        Some(s) => s.phase_value(phase, li, mu),
                        None => phase_value(phase, mu),
                    };
                    Some(p * irradiance)
                }
                Light::Point { .. } => None,
            })
            .collect();
        let mut incident = Vec::with_capacity(lights.len());
        let mut ms = self.ms.map(|m| MsCursor::new(m, wo));
        let medium = &self.scene.medium;
        let (mut trans, mut sum) = (1.0f64, 0.0f64);
        let cutoff = self.settings.cutoff;
        let delta = self.delta;
        self.pieces(origin, dir, t0, t1, |a, b| {
            let n = ((b - a) / delta).ceil().max(1.0);
            let dt = (b - a) / n;
            for s in 0..n as usize {
                let t = a + (s as f64 + 0.5) * dt;
                let x = [0, 1, 2].map(|d| origin[d] + t * dir[d]);
                let (sigma_t, sigma_s) = medium.coefficients_at(self.density, x);
                if sigma_t <= 0.0 {
                    continue;
                }
                let att = (-sigma_t * dt).exp();
                if sigma_s > 0.0 {
                    let mut src = 0.0;
                    incident.clear();
                    incident.extend(lights.iter().map(|l| l.incident(x)));
                    for (li, inc) in incident.iter().enumerate() {
                        if inc.irradiance == 0.0 {
                            continue;
                        }
                        let pe = match directional[li] {
                            Some(pe) => pe,
                            None => phase_value(phase, dot(inc.travel, wo)) * inc.irradiance,
                        };
                        if pe > 0.0 {
                            let back = inc.travel.map(|c| -c);
                            src += pe * (-self.tau_to_light(li, x, back, inc.distance)).exp();
                        }
                    }
                    if let Some(v) = sky {
                        src += v.eval(x);
                    }
                    if let Some(c) = ms.as_mut() {
                        src += c.eval(x);
                    }
                    sum += trans * (1.0 - att) * (sigma_s / sigma_t) * src;
                }
                trans *= att;
                if trans < cutoff {
                    return false;
                }
            }
            true
        });
        // Past the cutoff the rest of the ray is dropped: the background's share there is
        // below cutoff × its radiance.
        sum + trans * background
    }

    /// Calls `visit(t_a, t_b)` for the pieces of `origin + t·dir`, t ∈ [t0, t1], between
    /// consecutive planes of the cutting lattice whose cell is occupied, in order, until
    /// `visit` returns false (3D DDA, Amanatides & Woo).
    fn pieces(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        t0: f64,
        t1: f64,
        mut visit: impl FnMut(f64, f64) -> bool,
    ) {
        let [nx, ny, _] = self.cells;
        walk_lattice(
            origin,
            dir,
            t0,
            t1,
            self.lattice_min,
            self.h,
            self.cells,
            |ta, tb, cell| {
                let idx = (cell[2] as usize * ny + cell[1] as usize) * nx + cell[0] as usize;
                !self.occupied[idx] || visit(ta, tb)
            },
        );
    }

    /// Pixel (px, py) of `camera`: the mean over the k×k sub-pixel rays through
    /// `((a + ½)/k, (b + ½)/k)`,
    /// with the sky's single scattering read from `sky` (tabulated for the camera's
    /// position, [`Self::sky_view`]) where given.
    fn pixel_with<F: SkySource>(
        &self,
        camera: &Camera,
        px: usize,
        py: usize,
        sky: Option<&SkyView<F>>,
    ) -> f64 {
        let frame = camera.frame();
        let k = self.settings.rays_per_side().max(1);
        let mut sum = 0.0;
        for b in 0..k {
            for a in 0..k {
                let x = px as f64 + (a as f64 + 0.5) / k as f64;
                let y = py as f64 + (b as f64 + 0.5) / k as f64;
                sum += self.radiance_with(camera.position, camera.ray_dir(&frame, x, y), sky);
            }
        }
        sum / (k * k) as f64
    }

    /// Renders `camera`'s image, rows in parallel (the result does not depend on the number
    /// of threads); `rows` hears of the finished rows. The standard errors are 0 (no
    /// sampling).
    pub fn render(&self, camera: &Camera, rows: Option<&ProgressCallback>) -> Image {
        let (w, h) = (camera.width, camera.height);
        let sky = self.sky_view(camera.position);
        let counter = RowCounter::start(rows, h);
        let rows: Vec<Vec<f32>> = (0..h)
            .into_par_iter()
            .map(|py| {
                let row = (0..w)
                    .map(|px| self.pixel_with(camera, px, py, sky.as_ref()) as f32)
                    .collect();
                counter.row_done();
                row
            })
            .collect();
        Image {
            width: w,
            height: h,
            data: rows.into_iter().flatten().collect(),
            std_err: vec![0.0; w * h],
        }
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Parameter interval (t ≥ 0) of `origin + t·dir` inside the closed box, `None` if it misses.
fn clip_box(origin: [f64; 3], dir: [f64; 3], min: [f64; 3], max: [f64; 3]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for d in 0..3 {
        if dir[d] == 0.0 {
            if origin[d] < min[d] || origin[d] > max[d] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / dir[d];
        let (mut a, mut b) = ((min[d] - origin[d]) * inv, (max[d] - origin[d]) * inv);
        if a > b {
            std::mem::swap(&mut a, &mut b);
        }
        t0 = t0.max(a);
        t1 = t1.min(b);
    }
    (t0 < t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests;
